!> Galerkin quantities of the cantilever modes, docs/model.md §5, paper Eqs. (16)-(23).
!>
!> p = phi(xi0), s = phi'(xi0), c = phi''(xi0), q = int_0^1 phi, Lambda = diag(beta^4),
!> G_ij = int_0^xi_end phi_i phi_j''  (not symmetric).  Closed forms hold on [0, 1];
!> Gauss-Legendre quadrature covers any span and checks the closed forms.
module tmafm_galerkin
   use tmafm_kinds, only: dp
   use tmafm_modes, only: mode_shape, mode_sigma
   use tmafm_quadrature, only: composite_gauss_legendre
   implicit none
   private

   public :: mode_integrals_closed_form, axial_matrix_closed_form
   public :: mode_integrals_quadrature, axial_matrix_quadrature, mass_matrix_quadrature
   public :: quadrature_panels

   !> Gauss-Legendre points per panel of the composite rules.
   integer, parameter :: points_per_panel = 16

contains

   !> Number of panels that resolves modes up to root beta_max on a span of length `span`.
   pure function quadrature_panels(beta_max, span) result(n_panels)
      real(dp), intent(in) :: beta_max
      real(dp), intent(in) :: span
      integer :: n_panels
      n_panels = max(8, ceiling(2*beta_max*span))
   end function quadrature_panels

   !> q_i = int_0^1 phi_i = 2 sigma_i / beta_i.
   pure function mode_integrals_closed_form(beta) result(q)
      real(dp), intent(in) :: beta(:)
      real(dp) :: q(size(beta))
      q = 2*mode_sigma(beta)/beta
   end function mode_integrals_closed_form

   !> G_ij = int_0^1 phi_i phi_j'' from the boundary identities of the modes.
   pure function axial_matrix_closed_form(beta) result(g)
      real(dp), intent(in) :: beta(:)
      real(dp) :: g(size(beta), size(beta))
      real(dp) :: sigma(size(beta)), tip(size(beta)), tip_slope(size(beta)), b4(size(beta))
      real(dp) :: p_term, q_term
      integer :: i, j

      sigma = mode_sigma(beta)
      tip = mode_shape(beta, 1.0_dp, 0)
      tip_slope = mode_shape(beta, 1.0_dp, 1)
      b4 = beta**4
      do j = 1, size(beta)
         do i = 1, size(beta)
            if (i == j) then
               g(i, i) = sigma(i)*beta(i)*(2.0_dp - sigma(i)*beta(i))
            else
               ! beta_i^4 G_ij - beta_j^4 G_ji = P and G_ij - G_ji = Q.
               p_term = 4*beta(i)**2*beta(j)**2*(sigma(i)*beta(i) - sigma(j)*beta(j))
               q_term = tip(i)*tip_slope(j) - tip_slope(i)*tip(j)
               g(i, j) = (p_term - b4(j)*q_term)/(b4(i) - b4(j))
            end if
         end do
      end do
   end function axial_matrix_closed_form

   !> q_i = int_0^1 phi_i by composite Gauss-Legendre quadrature.
   pure function mode_integrals_quadrature(beta, n_panels) result(q)
      real(dp), intent(in) :: beta(:)
      integer, intent(in) :: n_panels
      real(dp) :: q(size(beta))
      real(dp) :: x(n_panels*points_per_panel), w(n_panels*points_per_panel)
      integer :: i

      call composite_gauss_legendre(0.0_dp, 1.0_dp, n_panels, points_per_panel, x, w)
      do i = 1, size(beta)
         q(i) = sum(w*mode_shape(beta(i), x, 0))
      end do
   end function mode_integrals_quadrature

   !> G_ij = int_0^xi_end phi_i phi_j'' by composite Gauss-Legendre quadrature.
   pure function axial_matrix_quadrature(beta, xi_end, n_panels) result(g)
      real(dp), intent(in) :: beta(:)
      real(dp), intent(in) :: xi_end
      integer, intent(in) :: n_panels
      real(dp) :: g(size(beta), size(beta))
      real(dp) :: x(n_panels*points_per_panel), w(n_panels*points_per_panel)
      real(dp) :: phi(n_panels*points_per_panel, size(beta))
      real(dp) :: curvature(n_panels*points_per_panel, size(beta))
      integer :: i, j

      call composite_gauss_legendre(0.0_dp, xi_end, n_panels, points_per_panel, x, w)
      do j = 1, size(beta)
         phi(:, j) = mode_shape(beta(j), x, 0)
         curvature(:, j) = mode_shape(beta(j), x, 2)
      end do
      do j = 1, size(beta)
         do i = 1, size(beta)
            g(i, j) = sum(w*phi(:, i)*curvature(:, j))
         end do
      end do
   end function axial_matrix_quadrature

   !> The Gram matrix int_0^1 phi_i phi_j by quadrature; the identity for orthonormal modes.
   pure function mass_matrix_quadrature(beta, n_panels) result(gram)
      real(dp), intent(in) :: beta(:)
      integer, intent(in) :: n_panels
      real(dp) :: gram(size(beta), size(beta))
      real(dp) :: x(n_panels*points_per_panel), w(n_panels*points_per_panel)
      real(dp) :: phi(n_panels*points_per_panel, size(beta))
      integer :: i, j

      call composite_gauss_legendre(0.0_dp, 1.0_dp, n_panels, points_per_panel, x, w)
      do j = 1, size(beta)
         phi(:, j) = mode_shape(beta(j), x, 0)
      end do
      do j = 1, size(beta)
         do i = 1, size(beta)
            gram(i, j) = sum(w*phi(:, i)*phi(:, j))
         end do
      end do
   end function mass_matrix_quadrature

end module tmafm_galerkin
