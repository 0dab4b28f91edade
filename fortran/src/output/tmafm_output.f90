!> The output of a run, in one of two formats, written so that no data are lost or clobbered.
!>
!> Formats: 'text' ('#' header lines echoing the resolved input and the version, then the
!> columns tau vt vtdot contact a_1..a_N adot_1..adot_N, for numpy.loadtxt), and 'npy' (a
!> .npz archive for numpy.load; layout in docs/output-format.md).  A scene given in &physical
!> adds its SI series (tmafm_physical_series): five more columns, or five more arrays.
!>
!> Targets: a regular file (or a missing one) is written under a unique temporary name in its
!> folder, synced, and renamed over the target only when complete; a character device or a
!> FIFO (/dev/null, /dev/stdout on a terminal or pipe) is written directly; '-' is standard
!> output.  Anything else (a folder, a symbolic link to a file, a socket) is refused.  Every
!> write, the sync and the close are checked; on failure the temporary is removed and nothing
!> is left under the target's name.
!>
!> The steps are separate so that the executable can check the target before the run
!> (prepare_output), open a device or FIFO before the run too (begin_output: a FIFO with no
!> reader is waited for then, with a line saying so, not after a long run), know the
!> temporary's name while it exists (begin_output .. write_output) to remove it on a signal,
!> and hold signals around the rename (commit_output) so that a complete file in place is
!> never reported as an interrupted run.
module tmafm_output
   use, intrinsic :: iso_c_binding, only: c_int32_t
   use tmafm_kinds, only: dp, i8
   use tmafm_errors, only: ok, err_input, err_file
   use tmafm_trajectory, only: trajectory_t
   use tmafm_config, only: config_t
   use tmafm_namelist, only: config_text
   use tmafm_version, only: tmafm_version_string
   use tmafm_text, only: int_text, lower
   use tmafm_float_format, only: put_es25, es25_width
   use tmafm_posix, only: kind_missing, kind_regular, kind_directory, kind_char_device, kind_fifo, &
                          kind_symlink, path_kind, create_temporary, open_device, open_device_now, &
                          check_descriptor, &
                          write_text, sync_descriptor, close_descriptor, rename_path, remove_path, &
                          check_writable, same_file, error_text
   use tmafm_physical_series, only: physical_series, n_series, series_names
   use tmafm_npz, only: npz_archive_t, npy_header, npz_begin, npz_add, npz_add_text, npz_finish, &
                        npz_bytes, max_npz_bytes, native_descr
   implicit none
   private

   public :: output_sink_t, prepare_output, check_output_size, begin_output, write_output, &
             commit_output, discard_output, write_trajectory_file, format_names, write_table
   public :: target_file, target_device, target_stdout

   !> How the target is written: through a temporary and a rename, directly, or to stdout.
   integer, parameter :: target_none = 0, target_file = 1, target_device = 2, target_stdout = 3
   !> Accepted values of &output format.
   character(len=*), parameter :: format_names = "'text' or 'npy'"
   !> Bytes of text gathered before each write(2).
   integer, parameter :: chunk_bytes = 1048576

   !> Where and how one run's output goes.
   type :: output_sink_t
      !> The target as given ('-' for standard output).
      character(len=:), allocatable :: path
      !> The temporary's name while it exists (target_file), else ''.
      character(len=:), allocatable :: temporary
      !> target_file, target_device or target_stdout (target_none before prepare_output).
      integer :: target = target_none
      !> .true. for the .npz format, .false. for text.
      logical :: binary = .false.
      !> Open descriptor (-1 when none).
      integer :: fd = -1
   end type output_sink_t

contains

   !> Check the target `path` for format `format` ('text' or 'npy') before the run: refuse what
   !> cannot or must not be written, and for a file, create and remove a temporary next to it
   !> (a caller that removes temporaries on signals should block them around this call).
   !> Nothing here blocks: a device or FIFO is only checked, and opened by begin_output.
   !> With `input_path`, a target that is the input file itself is refused (it would replace
   !> the user's input with the output).
   subroutine prepare_output(path, format, sink, ierr, errmsg, input_path)
      character(len=*), intent(in) :: path
      character(len=*), intent(in) :: format
      type(output_sink_t), intent(out) :: sink
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> The input file of the run, if any.
      character(len=*), intent(in), optional :: input_path
      character(len=:), allocatable :: name
      integer :: kind, target, status, j

      ierr = ok
      errmsg = ''
      sink%path = trim(path)
      sink%temporary = ''
      select case (trim(format))
      case ('text')
         sink%binary = .false.
      case ('npy')
         sink%binary = .true.
      case default
         call fail(err_input, '&output format = '''//trim(format)//''': must be '//format_names)
         return
      end select
      if (len(sink%path) == 0) then
         call fail(err_file, 'the output file name is empty (&output file or -o)')
         return
      end if
      do j = 1, len(sink%path)
         if (iachar(sink%path(j:j)) < 32 .or. iachar(sink%path(j:j)) == 127) then
            call fail(err_file, 'output file '//shown(sink%path)//': the name holds a control character')
            return
         end if
      end do
      if (sink%path == '-') then
         status = check_descriptor(1)
         if (status /= 0) then
            call fail(err_file, 'cannot write to standard output: '//error_text(status))
            return
         end if
         sink%target = target_stdout
         sink%fd = 1
         return
      end if
      kind = path_kind(sink%path, target)
      if (kind < 0) then
         call fail(err_file, 'cannot write output file '//shown(sink%path)//': '//error_text(kind))
         return
      end if
      if (kind == kind_symlink .and. (target == kind_char_device .or. target == kind_fifo)) kind = target
      select case (kind)
      case (kind_missing, kind_regular)
         ! The name says what the file is: .npz for the npy format, anything else for text.
         if (ends_with_npz(sink%path) .neqv. sink%binary) then
            if (sink%binary) then
               call fail(err_input, 'output file '//shown(sink%path)//': &output format = ''npy'' '// &
                         'writes a .npz archive; give a name ending in .npz')
            else
               call fail(err_input, 'output file '//shown(sink%path)//' ends in .npz but &output format = '// &
                         '''text''; set &output format = ''npy'' or choose another name')
            end if
            return
         end if

         if (kind == kind_regular .and. present(input_path)) then
            if (same_file(sink%path, input_path)) then
               call fail(err_file, 'output file '//shown(sink%path)//' is the input file '// &
                         shown(input_path)//': tmafm does not replace its own input; give '// &
                         'another name (-o or &output file)')
               return
            end if
         end if
         if (kind == kind_regular) then
            status = check_writable(sink%path)
            if (status /= 0) then
               call fail(err_file, 'output file '//shown(sink%path)//' exists and is not writable: '// &
                         error_text(status))
               return
            end if
         end if
         sink%target = target_file
         status = create_temporary(sink%path, name)
         if (status >= 0) then
            status = close_descriptor(status)
            if (status == 0) status = remove_path(name)
         end if
         if (status < 0) then
            call fail(err_file, 'cannot write output file '//shown(sink%path)//': '//error_text(status))
            return
         end if
      case (kind_char_device, kind_fifo)
         ! Checked only: opening and closing a FIFO now would end its reader's input.
         sink%target = target_device
         status = check_writable(sink%path)
         if (status /= 0) then
            call fail(err_file, 'cannot write output file '//shown(sink%path)//': '//error_text(status))
            return
         end if
      case (kind_directory)
         call fail(err_file, 'output file '//shown(sink%path)//' is a directory')
      case (kind_symlink)
         call fail(err_file, 'output file '//shown(sink%path)//' is a symbolic link; tmafm replaces only '// &
                   'regular files: give the path it points to')
      case default
         call fail(err_file, 'output file '//shown(sink%path)//' is not a regular file, a character '// &
                   'device or a FIFO')
      end select

   contains

      subroutine fail(code, message)
         integer, intent(in) :: code
         character(len=*), intent(in) :: message
         ierr = code
         errmsg = message
         sink%target = target_none
      end subroutine fail

   end subroutine prepare_output

   !> Refuse before the run an output the format cannot hold: a .npz beyond 4 GiB (no zip64).
   subroutine check_output_size(sink, n_samples, n_modes, ierr, errmsg, physical)
      type(output_sink_t), intent(in) :: sink
      integer(i8), intent(in) :: n_samples
      integer, intent(in) :: n_modes
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> .true. for a scene given in &physical (its SI series are written too).
      logical, intent(in), optional :: physical
      real(dp) :: gib
      integer(i8) :: per_sample

      ierr = ok
      errmsg = ''
      if (.not. sink%binary) return
      per_sample = 25_i8 + 16_i8*n_modes
      if (present(physical)) then
         if (physical) per_sample = per_sample + 8_i8*n_series
      end if
      ! The samples plus 1 MiB for headers, the resolved input and the switch times.
      gib = real(n_samples*per_sample + 1048576_i8, dp)/1073741824.0_dp
      if (gib*1073741824.0_dp > real(max_npz_bytes, dp)) then
         ierr = err_file
         write (errmsg, '(a,f0.1,a)') 'output file '//shown(sink%path)//' would hold ', gib, &
            ' GiB; a .npz is limited to 4 GiB (no zip64): raise &output sample_dtau or use format ''text'''
      end if
   end subroutine check_output_size

   !> Create the temporary file (target_file; from here until write_output returns, the
   !> temporary is sink%temporary), or open the device (a FIFO waits here for its reader, after
   !> a line on `notice_unit` saying so; a device already open is kept).
   subroutine begin_output(sink, ierr, errmsg, notice_unit)
      type(output_sink_t), intent(inout) :: sink
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> Where to say that tmafm waits for a FIFO's reader (nowhere if absent).
      integer, intent(in), optional :: notice_unit
      logical :: no_reader

      ierr = ok
      errmsg = ''
      select case (sink%target)
      case (target_file)
         sink%fd = create_temporary(sink%path, sink%temporary)
      case (target_device)
         if (sink%fd >= 0) return
         sink%fd = open_device_now(sink%path, no_reader)
         if (no_reader) then
            if (present(notice_unit)) then
               write (notice_unit, '(a)') 'tmafm: waiting for a reader of the FIFO '//shown(sink%path)// &
                  ' (the output goes there; Ctrl-C stops)'
               flush (notice_unit)
            end if
            sink%fd = open_device(sink%path)
         end if
      end select
      if (sink%fd < 0) then
         ierr = err_file
         errmsg = 'cannot write output file '//shown(sink%path)//': '//error_text(sink%fd)
         sink%temporary = ''
      end if
   end subroutine begin_output

   !> Write the run in the sink's format, then complete it: for a file, sync, close and rename
   !> the temporary over the target (with commit = .false., the rename is left to
   !> commit_output).  On any failure nothing is left but the target as it was.
   subroutine write_output(sink, input_path, config, traj, ierr, errmsg, commit)
      type(output_sink_t), intent(inout) :: sink
      character(len=*), intent(in) :: input_path
      type(config_t), intent(in) :: config
      type(trajectory_t), intent(in) :: traj
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> Rename the temporary over the target here (.true., the default).
      logical, intent(in), optional :: commit
      character(len=:), allocatable :: resolved
      integer :: status
      logical :: rename_now
      ! The SI series of a physical scene (0 columns for a dimensionless one).
      real(dp), allocatable :: series(:, :)

      ierr = ok
      errmsg = ''
      rename_now = .true.
      if (present(commit)) rename_now = commit
      if (sink%fd < 0) then
         ierr = err_file
         errmsg = 'output file '//shown(sink%path)//' was not opened'
         return
      end if
      call config_text(config, resolved)
      allocate (series(size(traj%tau), merge(n_series, 0, config%from_physical)))
      if (config%from_physical) call physical_series(config, traj, series, ierr, errmsg)
      if (ierr /= ok) then
         call discard_output(sink)
         return
      end if
      if (sink%binary) then
         call write_npz(sink, config, traj, resolved, series, ierr, errmsg, status)
      else
         call write_text_format(sink%fd, input_path, config, traj, resolved, series, status)
      end if
      call finish_output(sink, rename_now, status, ierr, errmsg)
   end subroutine write_output

   !> After the bytes: for a file, sync, close and (with rename_now) rename the temporary over
   !> the target; close a device.  A failed write (status /= 0) or any failure here is ierr =
   !> err_file, and then, as on an earlier error (ierr /= ok), the output is discarded.
   subroutine finish_output(sink, rename_now, status, ierr, errmsg)
      type(output_sink_t), intent(inout) :: sink
      logical, intent(in) :: rename_now
      integer, intent(inout) :: status
      integer, intent(inout) :: ierr
      character(len=*), intent(inout) :: errmsg
      if (ierr == ok .and. status == 0 .and. sink%target == target_file) then
         status = sync_descriptor(sink%fd)
         if (status == 0) then
            status = close_descriptor(sink%fd)
            sink%fd = -1
         end if
         if (status == 0 .and. rename_now) status = rename_path(sink%temporary, sink%path)
         if (status == 0 .and. rename_now) sink%temporary = ''
      else if (ierr == ok .and. status == 0 .and. sink%target == target_device) then
         status = close_descriptor(sink%fd)
         sink%fd = -1
      end if
      if (ierr == ok .and. status /= 0) then
         ierr = err_file
         errmsg = 'writing output file '//shown(sink%path)//' failed: '//error_text(status)
      end if
      if (ierr /= ok) call discard_output(sink)
   end subroutine finish_output

   !> Write a table of `config`'s instrument run (&scan, &fm: docs/output-format.md) in the
   !> sink's format, then complete it as write_output does.  Text: the '#' header (version,
   !> input, the resolved input, then `notes`' lines), '# columns:' and '# units:' lines, one
   !> row of values(k, :) per line.  npy: one array '<name>.npy' per column, and the texts
   !> 'resolved.npy', 'notes.npy' and 'version.npy'.
   subroutine write_table(sink, input_path, config, notes, names, units, values, ierr, errmsg, commit)
      type(output_sink_t), intent(inout) :: sink
      character(len=*), intent(in) :: input_path
      type(config_t), intent(in) :: config
      !> Lines (each ended by new_line('a')) on what the run measured and how.
      character(len=*), intent(in) :: notes
      character(len=*), intent(in) :: names(:)
      character(len=*), intent(in) :: units(:)
      real(dp), intent(in) :: values(:, :)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> Rename the temporary over the target here (.true., the default).
      logical, intent(in), optional :: commit
      character(len=:), allocatable :: resolved, text, version, h_vector, h_resolved, h_notes, h_version
      type(npz_archive_t) :: archive
      integer(i8) :: n
      integer :: status, k, j, used
      logical :: rename_now

      ierr = ok
      errmsg = ''
      status = 0
      rename_now = .true.
      if (present(commit)) rename_now = commit
      if (sink%fd < 0) then
         ierr = err_file
         errmsg = 'output file '//shown(sink%path)//' was not opened'
         return
      end if
      call config_text(config, resolved)
      version = 'tmafm '//tmafm_version_string
      if (sink%binary) then
         n = size(values, 1, kind=i8)
         h_vector = npy_header(native_descr('f8'), .false., [n])
         h_resolved = npy_header('|S'//int_text(int(len(resolved), i8)), .false., [integer(i8) ::])
         h_notes = npy_header('|S'//int_text(int(len(notes), i8)), .false., [integer(i8) ::])
         h_version = npy_header('|S'//int_text(int(len(version), i8)), .false., [integer(i8) ::])
         call npz_begin(archive, sink%fd)
         do j = 1, size(names)
            if (status == 0) call npz_add(archive, trim(names(j))//'.npy', h_vector, values(:, j), 8*n, status)
         end do
         if (status == 0) call npz_add_text(archive, 'resolved.npy', h_resolved, resolved, status)
         if (status == 0) call npz_add_text(archive, 'notes.npy', h_notes, notes, status)
         if (status == 0) call npz_add_text(archive, 'version.npy', h_version, version, status)
         if (status == 0) call npz_finish(archive, status)
      else
         text = '# '//version//new_line('a')//'# input: '//printable(trim(input_path))//new_line('a')// &
                prefixed(resolved, '# ')//prefixed(notes, '# ')//'# columns:'
         do j = 1, size(names)
            text = text//' '//trim(names(j))
         end do
         text = text//new_line('a')//'# units:'
         do j = 1, size(units)
            text = text//' '//trim(units(j))
         end do
         status = write_text(sink%fd, text//new_line('a'))
         deallocate (text)
         allocate (character(len=size(values, 2)*es25_width + 1) :: text)
         do k = 1, size(values, 1)
            if (status /= 0) exit
            used = 0
            do j = 1, size(values, 2)
               call put_es25(text, used + 1, values(k, j))
               used = used + es25_width
            end do
            text(used + 1:used + 1) = new_line('a')
            status = write_text(sink%fd, text(1:used + 1))
         end do
      end if
      call finish_output(sink, rename_now, status, ierr, errmsg)
   end subroutine write_table

   !> Put a file written by write_output(commit = .false.) in place: rename the temporary over
   !> the target (nothing to do for a device or standard output).  On failure the temporary is
   !> removed and the target left as it was.
   subroutine commit_output(sink, ierr, errmsg)
      type(output_sink_t), intent(inout) :: sink
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer :: status

      ierr = ok
      errmsg = ''
      if (sink%target /= target_file) return
      ierr = err_file
      errmsg = 'output file '//shown(sink%path)//' was not written'
      if (.not. allocated(sink%temporary)) return
      if (len(sink%temporary) == 0 .or. sink%fd >= 0) then
         call discard_output(sink)
         return
      end if
      status = rename_path(sink%temporary, sink%path)
      if (status == 0) then
         ierr = ok
         errmsg = ''
         sink%temporary = ''
         return
      end if
      errmsg = 'writing output file '//shown(sink%path)//' failed: '//error_text(status)
      call discard_output(sink)
   end subroutine commit_output

   !> Give up the output: close the descriptor (never standard output) and remove the temporary.
   subroutine discard_output(sink)
      type(output_sink_t), intent(inout) :: sink
      integer :: status
      if (sink%fd >= 0 .and. sink%target /= target_stdout) status = close_descriptor(sink%fd)
      sink%fd = -1
      if (allocated(sink%temporary)) then
         if (len(sink%temporary) > 0) status = remove_path(sink%temporary)
         sink%temporary = ''
      end if
   end subroutine discard_output

   !> Write `traj` of `config` to `path` in one call (prepare, begin, write), in `format`
   !> ('text' unless given).  For library users; the executable calls the steps itself.
   subroutine write_trajectory_file(path, input_path, config, traj, ierr, errmsg, format)
      character(len=*), intent(in) :: path
      character(len=*), intent(in) :: input_path
      type(config_t), intent(in) :: config
      type(trajectory_t), intent(in) :: traj
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      !> 'text' (the default) or 'npy'.
      character(len=*), intent(in), optional :: format
      type(output_sink_t) :: sink

      if (present(format)) then
         call prepare_output(path, format, sink, ierr, errmsg)
      else
         call prepare_output(path, 'text', sink, ierr, errmsg)
      end if
      if (ierr /= ok) return
      call check_output_size(sink, int(size(traj%tau), i8), config%n_modes, ierr, errmsg, &
                             config%from_physical)
      if (ierr == ok) call begin_output(sink, ierr, errmsg)
      if (ierr == ok) call write_output(sink, input_path, config, traj, ierr, errmsg)
      if (ierr /= ok) call discard_output(sink)
   end subroutine write_trajectory_file

   !> The text format: header lines, then one row per sample, gathered in 1 MiB chunks.
   subroutine write_text_format(fd, input_path, config, traj, resolved, series, status)
      integer, intent(in) :: fd
      character(len=*), intent(in) :: input_path
      type(config_t), intent(in) :: config
      type(trajectory_t), intent(in) :: traj
      character(len=*), intent(in) :: resolved
      !> The SI series (samples x 0 for a dimensionless scene), after the other columns.
      real(dp), intent(in) :: series(:, :)
      integer, intent(out) :: status
      character(len=:), allocatable :: header, buffer
      character(len=24) :: number
      integer :: n, k, j, row_bytes, used, rows
      integer(i8) :: chunk

      n = config%n_modes
      header = '# tmafm '//tmafm_version_string//new_line('a')//'# input: '//printable(trim(input_path))// &
               new_line('a')//prefixed(resolved, '# ')
      header = header//'# counters: steps = '//int_text(traj%steps)//', contact_steps = '// &
               int_text(traj%contact_steps)//', rejected_steps = '//int_text(traj%rejected_steps)// &
               ', rhs_evaluations = '//int_text(traj%rhs_evaluations)//', phase_switches = '// &
               int_text(int(traj%n_switches, i8))//new_line('a')//'# columns: tau vt vtdot contact'
      do j = 1, n
         write (number, '(i0)') j
         header = header//' a_'//trim(number)
      end do
      do j = 1, n
         write (number, '(i0)') j
         header = header//' adot_'//trim(number)
      end do
      do j = 1, size(series, 2)
         header = header//' '//trim(series_names(j))
      end do
      status = write_text(fd, header//new_line('a'))
      if (status /= 0) return

      row_bytes = (3 + 2*n + size(series, 2))*es25_width + 3 + 1
      rows = size(traj%tau)
      chunk = max(int(row_bytes, i8), min(int(chunk_bytes, i8), int(row_bytes, i8)*rows))
      allocate (character(len=chunk) :: buffer)
      used = 0
      do k = 1, rows
         if (used + row_bytes > len(buffer)) then
            status = write_text(fd, buffer(1:used))
            if (status /= 0) return
            used = 0
         end if
         call put_es25(buffer, used + 1, traj%tau(k))
         call put_es25(buffer, used + 1 + es25_width, traj%vt(k))
         call put_es25(buffer, used + 1 + 2*es25_width, traj%vtdot(k))
         used = used + 3*es25_width
         if (traj%contact(k) >= 0 .and. traj%contact(k) <= 9) then
            buffer(used + 1:used + 3) = '  '//achar(48 + traj%contact(k))
         else
            write (buffer(used + 1:used + 3), '(i3)') traj%contact(k)
         end if
         used = used + 3
         do j = 1, n
            call put_es25(buffer, used + 1, traj%a(k, j))
            used = used + es25_width
         end do
         do j = 1, n
            call put_es25(buffer, used + 1, traj%adot(k, j))
            used = used + es25_width
         end do
         do j = 1, size(series, 2)
            call put_es25(buffer, used + 1, series(k, j))
            used = used + es25_width
         end do
         buffer(used + 1:used + 1) = new_line('a')
         used = used + 1
      end do
      status = write_text(fd, buffer(1:used))
   end subroutine write_text_format

   !> The npy format: a .npz archive (layout in docs/output-format.md).
   subroutine write_npz(sink, config, traj, resolved, series, ierr, errmsg, status)
      type(output_sink_t), intent(in) :: sink
      type(config_t), intent(in) :: config
      type(trajectory_t), intent(in) :: traj
      character(len=*), intent(in) :: resolved
      !> The SI series (samples x 0 for a dimensionless scene): one array each, after the others.
      real(dp), intent(in) :: series(:, :)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      integer, intent(out) :: status
      character(len=*), parameter :: names(10) = [character(len=12) :: 'tau.npy', 'vt.npy', 'vtdot.npy', &
                                                  'contact.npy', 'a.npy', 'adot.npy', 'switches.npy', &
                                                  'counters.npy', 'resolved.npy', 'version.npy']
      character(len=:), allocatable :: version, h_vector, h_contact, h_matrix, h_switches, h_counters, &
                                       h_resolved, h_version
      integer(i8) :: n, n_modes, n_switches, bytes(10), total
      integer(i8) :: counters(5)
      integer :: j
      integer(kind=selected_int_kind(2)), allocatable :: contact(:)
      type(npz_archive_t) :: archive
      real(dp) :: gib

      ierr = ok
      errmsg = ''
      n = size(traj%tau, kind=i8)
      n_modes = config%n_modes
      n_switches = traj%n_switches
      version = 'tmafm '//tmafm_version_string
      h_vector = npy_header(native_descr('f8'), .false., [n])
      h_contact = npy_header(native_descr('i1'), .false., [n])
      h_matrix = npy_header(native_descr('f8'), .true., [n, n_modes])
      h_switches = npy_header(native_descr('f8'), .false., [n_switches])
      h_counters = npy_header(native_descr('i8'), .false., [5_i8])
      h_resolved = npy_header('|S'//int_text(int(len(resolved), i8)), .false., [integer(i8) ::])
      h_version = npy_header('|S'//int_text(int(len(version), i8)), .false., [integer(i8) ::])
      bytes = [len(h_vector) + 8*n, len(h_vector) + 8*n, len(h_vector) + 8*n, len(h_contact) + n, &
               len(h_matrix) + 8*n*n_modes, len(h_matrix) + 8*n*n_modes, len(h_switches) + 8*n_switches, &
               len(h_counters) + 40_i8, int(len(h_resolved) + len(resolved), i8), &
               int(len(h_version) + len(version), i8)]
      ! The archive's bytes, the SI series (each '<name>.npy', a vector) included.
      total = npz_bytes([len_trim(names), (len_trim(series_names(j)) + 4, j = 1, size(series, 2))], &
                        [bytes, (len(h_vector) + 8*n, j = 1, size(series, 2))])
      if (total > max_npz_bytes) then
         ierr = err_file
         gib = real(total, dp)/1073741824.0_dp
         write (errmsg, '(a,f0.1,a)') 'output file '//shown(sink%path)//' would hold ', gib, &
            ' GiB; a .npz is limited to 4 GiB (no zip64): raise &output sample_dtau or use format ''text'''
         status = 0
         return
      end if
      contact = int(traj%contact, kind(contact))
      counters = [traj%steps, traj%contact_steps, traj%rejected_steps, traj%rhs_evaluations, n_switches]

      call npz_begin(archive, sink%fd)
      call npz_add(archive, 'tau.npy', h_vector, traj%tau, 8*n, status)
      if (status == 0) call npz_add(archive, 'vt.npy', h_vector, traj%vt, 8*n, status)
      if (status == 0) call npz_add(archive, 'vtdot.npy', h_vector, traj%vtdot, 8*n, status)
      if (status == 0) call npz_add(archive, 'contact.npy', h_contact, contact, n, status)
      if (status == 0) call npz_add(archive, 'a.npy', h_matrix, traj%a, 8*n*n_modes, status)
      if (status == 0) call npz_add(archive, 'adot.npy', h_matrix, traj%adot, 8*n*n_modes, status)
      if (status == 0) call npz_add(archive, 'switches.npy', h_switches, traj%switch_tau, 8*n_switches, status)
      if (status == 0) call npz_add(archive, 'counters.npy', h_counters, counters, 40_i8, status)
      if (status == 0) call npz_add_text(archive, 'resolved.npy', h_resolved, resolved, status)
      if (status == 0) call npz_add_text(archive, 'version.npy', h_version, version, status)
      do j = 1, size(series, 2)
         if (status == 0) call npz_add(archive, trim(series_names(j))//'.npy', h_vector, series(:, j), 8*n, status)
      end do
      if (status == 0) call npz_finish(archive, status)
   end subroutine write_npz

   !> Every line of `text` with `prefix` in front.
   !> (Its length is computed from the arguments: a deferred-length result is not thread-safe
   !> with gfortran 12, see tmafm_text.)
   pure function prefixed(text, prefix) result(out)
      character(len=*), intent(in) :: text, prefix
      character(len=prefixed_length(text, len(prefix))) :: out
      integer :: start, stop, n
      n = 0
      start = 1
      do while (start <= len(text))
         stop = index(text(start:), new_line('a'))
         if (stop == 0) then
            out(n + 1:) = prefix//text(start:)//new_line('a')
            exit
         end if
         out(n + 1:n + len(prefix) + stop) = prefix//text(start:start + stop - 1)
         n = n + len(prefix) + stop
         start = start + stop
      end do
   end function prefixed

   !> Length of prefixed(text, prefix) for a prefix of prefix_length characters.
   pure integer function prefixed_length(text, prefix_length)
      character(len=*), intent(in) :: text
      integer, intent(in) :: prefix_length
      integer :: lines
      lines = count_newlines(text)
      prefixed_length = len(text)
      if (len(text) > 0) then
         if (text(len(text):) /= new_line('a')) then
            lines = lines + 1
            prefixed_length = prefixed_length + 1
         end if
      end if
      prefixed_length = prefixed_length + lines*prefix_length
   end function prefixed_length

   pure integer function count_newlines(text)
      character(len=*), intent(in) :: text
      integer :: j
      count_newlines = 0
      do j = 1, len(text)
         if (text(j:j) == new_line('a')) count_newlines = count_newlines + 1
      end do
   end function count_newlines

   !> `text` with control characters shown as '?', so a header line stays one line.
   pure function printable(text) result(out)
      character(len=*), intent(in) :: text
      character(len=len(text)) :: out
      integer :: j
      out = text
      do j = 1, len(text)
         if (iachar(text(j:j)) < 32 .or. iachar(text(j:j)) == 127) out(j:j) = '?'
      end do
   end function printable

   !> A path for a message: quoted, and shortened in the middle past 200 characters.
   pure function shown(path) result(text)
      character(len=*), intent(in) :: path
      character(len=merge(len(path), 183, len(path) <= 200) + 2) :: text
      if (len(path) <= 200) then
         text = ''''//printable(path)//''''
      else
         text = ''''//printable(path(1:60))//'...'//printable(path(len(path) - 119:))//''''
      end if
   end function shown

   pure function ends_with_npz(path) result(yes)
      character(len=*), intent(in) :: path
      logical :: yes
      yes = .false.
      if (len(path) < 4) return
      yes = lower(path(len(path) - 3:)) == '.npz'
   end function ends_with_npz

end module tmafm_output
