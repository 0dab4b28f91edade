!> The tmafm command: run a namelist file and write the sampled trajectory.
!>
!> Exit status: 0 success, 1 bad command line, 2 bad input, 3 file error,
!> 4 blow-up, 5 other run failure.  Errors go to stderr as one line.
program tmafm_main
   use, intrinsic :: iso_fortran_env, only: error_unit, output_unit
   use tmafm, only: config_t, trajectory_t, read_config, simulate, write_trajectory_file, &
      choose_mode_count, &
      tmafm_version_string, ok, errmsg_len, path_len
   implicit none

   character(len=path_len) :: input_path, output_override, argument
   character(len=errmsg_len) :: errmsg
   type(config_t) :: config
   type(trajectory_t) :: traj
   integer :: i, n_args, ierr
   logical :: quiet

   input_path = ''
   output_override = ''
   quiet = .false.
   n_args = command_argument_count()
   i = 1
   do while (i <= n_args)
      call get_command_argument(i, argument)
      select case (trim(argument))
      case ('-h', '--help')
         call print_help()
         stop
      case ('-V', '--version')
         write (output_unit, '(a)') 'tmafm '//tmafm_version_string
         stop
      case ('-q', '--quiet')
         quiet = .true.
      case ('-o', '--output')
         if (i == n_args) call fail(1, 'option '//trim(argument)//' needs a file name')
         i = i + 1
         call get_command_argument(i, output_override)
      case default
         if (argument(1:1) == '-') call fail(1, 'unknown option '''//trim(argument)// &
                                              ''' (see tmafm --help)')
         if (len_trim(input_path) > 0) call fail(1, 'more than one input file given: '''// &
                                                   trim(input_path)//''' and '''//trim(argument)//'''')
         input_path = argument
      end select
      i = i + 1
   end do
   if (len_trim(input_path) == 0) call fail(1, 'no input file given (usage: tmafm INPUT.nml [-o FILE])')

   call read_config(input_path, config, ierr, errmsg)
   if (ierr /= ok) call fail(ierr, errmsg)
   if (len_trim(output_override) > 0) config%output_file = output_override
   call choose_mode_count(config, ierr, errmsg)
   if (ierr /= ok) call fail(ierr, errmsg)

   if (quiet) then
      call simulate(config, traj, ierr, errmsg)
   else
      call simulate(config, traj, ierr, errmsg, progress_unit=error_unit)
   end if
   if (ierr /= ok) call fail(ierr, errmsg)

   call write_trajectory_file(config%output_file, input_path, config, traj, ierr, errmsg)
   if (ierr /= ok) call fail(ierr, errmsg)
   if (.not. quiet) write (output_unit, '(a,i0,a)') 'tmafm: wrote ', size(traj%tau), &
      ' samples to '//trim(config%output_file)

contains

   subroutine fail(code, message)
      integer, intent(in) :: code
      character(len=*), intent(in) :: message
      write (error_unit, '(a)') 'tmafm: error: '//trim(message)
      stop code, quiet=.true.
   end subroutine fail

   subroutine print_help()
      write (output_unit, '(a)') &
         'usage: tmafm INPUT.nml [-o FILE] [-q]', &
         '', &
         'Run the tapping-mode AFM model described by the namelist file INPUT.nml and', &
         'write the sampled trajectory (columns tau vt vtdot contact a_1..a_N adot_1..adot_N,', &
         'after # header lines that echo the fully resolved input).', &
         '', &
         '  -o, --output FILE   write to FILE instead of &output file', &
         '  -q, --quiet         no progress lines on stderr, no summary on stdout', &
         '  -h, --help          show this help', &
         '  -V, --version       show the version', &
         '', &
         'Groups: &model &scene (or &physical, SI units) &initial &solver &output.', &
         'Exit status: 0 ok, 1 usage, 2 bad input, 3 file error, 4 blow-up, 5 run failure.'
   end subroutine print_help

end program tmafm_main
