!> The tmafm command: run a namelist file and write the sampled trajectory.
!>
!> Exit status: 0 success, 1 bad command line, 2 bad input, 3 file error,
!> 4 blow-up, 5 other run failure.  Errors go to stderr as one line.  A terminating signal
!> (SIGINT, SIGTERM, SIGHUP, ...) removes the output's temporary file (tmafm_signals.c) before
!> the process dies; once the output is complete in place, the run has succeeded and such a
!> signal ends it with status 0.
program tmafm_main
   use, intrinsic :: iso_c_binding, only: c_char, c_size_t
   use, intrinsic :: iso_fortran_env, only: error_unit
   use tmafm, only: config_t, trajectory_t, read_config, simulate, choose_mode_count, i8, &
      tmafm_version_string, ok, errmsg_len, path_len, output_sink_t, prepare_output, &
      check_output_size, begin_output, write_output, discard_output, sample_count, target_file, &
      target_device, printable_text, commit_output, write_text, error_text, int_text
   ! The instrument (&scan, &fm: docs/instrument.md), whose output is a table.
   use tmafm, only: dp, real_text, run_am_scan, n_scan_columns, scan_column_names, scan_column_units, &
      n_scan_info, scan_info_names, scan_info_units, n_record_columns, material_b_physical, fm_loop_t, &
      init_fm_loop, fm_point, n_fm_columns, fm_column_names, fm_column_units, fm_z_points, write_table
   implicit none

   interface
      subroutine tmafm_signals_install() bind(c, name='tmafm_signals_install')
      end subroutine tmafm_signals_install
      subroutine tmafm_signals_hold() bind(c, name='tmafm_signals_hold')
      end subroutine tmafm_signals_hold
      subroutine tmafm_signals_guard(name, n) bind(c, name='tmafm_signals_guard')
         import :: c_char, c_size_t
         character(kind=c_char), intent(in) :: name(*)
         integer(c_size_t), value :: n
      end subroutine tmafm_signals_guard
      subroutine tmafm_signals_release() bind(c, name='tmafm_signals_release')
      end subroutine tmafm_signals_release
      subroutine tmafm_signals_complete() bind(c, name='tmafm_signals_complete')
      end subroutine tmafm_signals_complete
   end interface

   character(len=:), allocatable :: input_path, output_override, argument, output_format, output_target
   character(len=errmsg_len) :: errmsg
   type(config_t) :: config
   type(trajectory_t) :: traj
   type(output_sink_t) :: sink
   integer :: i, n_args, ierr
   logical :: quiet, have_input, have_output, timings
   real :: cpu(3)
   integer(i8) :: clock(3), clock_rate
   ! An instrument run's table: its columns' names and units, rows, and the notes for its header.
   logical :: instrument
   character(len=32), allocatable :: names(:), units(:)
   real(dp), allocatable :: table(:, :)
   character(len=:), allocatable :: notes

   call tmafm_signals_install()
   have_input = .false.
   have_output = .false.
   quiet = .false.
   timings = .false.
   n_args = command_argument_count()
   i = 1
   do while (i <= n_args)
      call get_argument(i, argument)
      select case (argument)
      case ('-h', '--help')
         call print_stdout(help_text(), 'the help text')
         stop
      case ('-V', '--version')
         call print_stdout('tmafm '//tmafm_version_string//new_line('a'), 'the version')
         stop
      case ('-q', '--quiet')
         quiet = .true.
      case ('--timings')
         timings = .true.
      case ('-o', '--output')
         if (i == n_args) call fail(1, 'option '//argument//' needs a file name (or - for standard output)')
         i = i + 1
         if (have_output) call fail(1, 'option '//argument//' given twice: give one output file')
         call get_argument(i, output_override)
         call check_path_length(output_override, 'output file name')
         if (len(output_override) == 0) call fail(1, 'option '//argument//' needs a file name, not ''''')
         ! A blank around the name would be dropped (Fortran strings): refused, not changed.
         if (output_override(1:1) == ' ' .or. output_override(len(output_override):) == ' ') &
            call fail(1, 'option '//argument//' '''//output_override//''': the name begins or ends with a '// &
                      'blank, which tmafm would not keep')
         have_output = .true.
      case default
         if (len(argument) > 0) then
            if (argument(1:1) == '-') call fail(1, 'unknown option '''//shortened(argument)// &
                                                ''' (see tmafm --help)')
         end if
         if (have_input) call fail(1, 'more than one input file given: '''//shortened(input_path)// &
                                   ''' and '''//shortened(argument)//'''')
         call check_path_length(argument, 'input file name')
         input_path = argument
         have_input = .true.
      end select
      i = i + 1
   end do
   if (.not. have_input) call fail(1, 'no input file given (usage: tmafm INPUT.nml [-o FILE])')

   ! A FIFO nobody writes to is waited for with a line on stderr, never silently.
   call read_config(input_path, config, ierr, errmsg, notice_unit=error_unit)
   if (ierr /= ok) call fail(ierr, errmsg)
   ! -o - is standard output; the header keeps the input's &output file then, so that it stays
   ! a valid input ('-' in a namelist is refused as ambiguous).
   if (have_output .and. output_override /= '-') config%output_file = output_override
   output_format = trim(config%output_format)
   if (have_output) then
      output_target = output_override
   else
      output_target = trim(config%output_file)
   end if

   ! The target is checked before anything is integrated.  The check creates and removes a
   ! temporary: signals wait meanwhile, so none can leave it behind.
   call tmafm_signals_hold()
   call prepare_output(output_target, output_format, sink, ierr, errmsg, input_path=input_path)
   call tmafm_signals_release()
   if (ierr /= ok) call fail(ierr, errmsg)
   ! A device or FIFO is opened before the run too: a FIFO with no reader is waited for now,
   ! with a line on stderr, and not after the whole run (signals stop the wait as usual).
   if (sink%target == target_device) call begin_output(sink, ierr, errmsg, notice_unit=error_unit)
   if (ierr /= ok) call fail(ierr, errmsg)

   call mark(1)
   instrument = config%has_scan .or. config%has_fm
   if (config%has_scan) then
      call scan_table(ierr, errmsg)
   else if (config%has_fm) then
      call fm_table(ierr, errmsg)
   else if (quiet) then
      call choose_mode_count(config, ierr, errmsg)
   else
      call choose_mode_count(config, ierr, errmsg, progress_unit=error_unit)
   end if
   if (ierr == ok .and. .not. instrument) call check_output_size(sink, int(sample_count(config%solver), i8), &
                                                                 config%n_modes, ierr, errmsg, config%from_physical)
   if (ierr == ok .and. .not. instrument) then
      if (quiet) then
         call simulate(config, traj, ierr, errmsg)
      else
         call simulate(config, traj, ierr, errmsg, progress_unit=error_unit)
      end if
   end if
   if (ierr /= ok) then
      call discard_output(sink)
      call fail(ierr, errmsg)
   end if
   call mark(2)

   ! Signals wait from the temporary's creation until the handler knows its name (a device or
   ! FIFO is already open).
   if (sink%target == target_file) then
      call tmafm_signals_hold()
      call begin_output(sink, ierr, errmsg)
      if (ierr == ok) then
         call tmafm_signals_guard(sink%temporary, len(sink%temporary, kind=c_size_t))
      else
         call tmafm_signals_release()
      end if
   end if
   if (ierr == ok .and. instrument) then
      call write_table(sink, input_path, config, notes, names, units, table, ierr, errmsg, commit=.false.)
   else if (ierr == ok) then
      call write_output(sink, input_path, config, traj, ierr, errmsg, commit=.false.)
   end if
   if (ierr == ok) then
      ! Signals wait across the rename: once the complete file is in place, the run has
      ! succeeded, and a signal that came meanwhile or comes later ends it with status 0
      ! (before, one right after the rename died with 128 + signo over a finished file).
      call tmafm_signals_hold()
      call commit_output(sink, ierr, errmsg)
      if (ierr == ok) call tmafm_signals_complete()
   end if
   call tmafm_signals_release()
   if (ierr /= ok) call fail(ierr, errmsg)
   call mark(3)
   if (timings) write (error_unit, '(a)') 'tmafm: timings: run '//seconds(cpu(2) - cpu(1))//' s CPU, write '// &
      seconds(cpu(3) - cpu(2))//' s CPU ('//seconds(real(clock(3) - clock(2))/real(clock_rate))//' s wall)'
   ! The summary goes to stdout, unless stdout holds the data.
   if (.not. quiet .and. sink%path /= '-') then
      if (instrument) then
         call print_stdout('tmafm: wrote '//int_text(size(table, 1))//' rows to '//trim(config%output_file)// &
                           new_line('a'), 'the summary')
      else
         call print_stdout('tmafm: wrote '//int_text(size(traj%tau))//' samples to '//trim(config%output_file)// &
                           new_line('a'), 'the summary')
      end if
   end if

contains

   !> &scan: one scan line (run_am_scan); the table has one row per pixel and pass: direction
   !> (0 trace, 1 retrace), x (nm, the pixel's centre), the pixel means; the notes what the
   !> engage measured.
   subroutine scan_table(ierr, errmsg)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      real(dp), allocatable :: pixels(:, :, :), record(:, :)
      real(dp) :: info(n_scan_info)
      integer :: passes, n, p, j, k

      n = config%scan%pixels
      passes = merge(2, 1, config%scan%retrace)
      allocate (pixels(n, n_scan_columns, passes), record(0, n_record_columns))
      if (.not. quiet) write (error_unit, '(a)') 'tmafm: scan: '//int_text(n)//' pixels, '// &
         trim(merge('trace and retrace', 'trace            ', passes == 2))//', engage first'
      call run_am_scan(config, material_b_physical(config), config%scan, pixels, info, record, ierr, errmsg)
      if (ierr /= ok) return
      names = [character(len=32) :: 'direction', 'x', scan_column_names]
      units = [character(len=32) :: '1', 'nm', scan_column_units]
      allocate (table(n*passes, 2 + n_scan_columns))
      do p = 1, passes
         do j = 1, n
            k = (p - 1)*n + j
            table(k, 1) = p - 1
            table(k, 2) = (j - 0.5_dp)*config%scan%scan_length/n*1.0e9_dp
            table(k, 3:) = pixels(j, :, p)
         end do
      end do
      notes = 'scan: one row per pixel and pass: direction 0 the trace, 1 the retrace; x the pixel''s '// &
              'centre; the rest the means over the pixel''s drive periods'//new_line('a')
      do k = 1, n_scan_info
         notes = notes//'engage: '//trim(scan_info_names(k))//' = '//real_text(info(k))//' '// &
                 trim(scan_info_units(k))//new_line('a')
      end do
   end subroutine scan_table

   !> &fm: the FM approach, Z point after Z point from the last one's loop state (init_fm_loop,
   !> fm_point); the table has one row per point (the columns of tmafm_fm), the notes the free
   !> reference.
   subroutine fm_table(ierr, errmsg)
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(fm_loop_t) :: loop
      real(dp), allocatable :: z(:)
      integer :: k

      z = fm_z_points(config)
      call init_fm_loop(loop, config, config%fm, ierr, errmsg)
      if (ierr /= ok) return
      allocate (table(size(z), n_fm_columns))
      do k = 1, size(z)
         call fm_point(loop, z(k), table(k, :), ierr, errmsg)
         if (ierr /= ok) then
            errmsg = 'fm: Z point '//int_text(k)//' (z = '//real_text(z(k))//' m): '//trim(errmsg)
            return
         end if
         if (.not. quiet) write (error_unit, '(a)') 'tmafm: fm: Z point '//int_text(k)//' of '// &
            int_text(size(z))//': z = '//real_text(table(k, 1))//' nm, df = '//real_text(table(k, 2))//' Hz'
      end do
      names = [character(len=32) :: fm_column_names]
      units = [character(len=32) :: fm_column_units]
      notes = 'fm: one row per Z point, each the average over average_periods after settle_periods'// &
              new_line('a')//'reference: f0 = '//real_text(loop%free_frequency)//' Hz'//new_line('a')// &
              'reference: phase_setpoint = '//real_text(loop%phase_setpoint)//' deg'//new_line('a')// &
              'reference: free_drive = '//real_text(loop%free_drive*1.0e9_dp)//' nm'//new_line('a')// &
              'reference: free_drive_work = '//real_text(loop%free_work)//' aJ'//new_line('a')// &
              'reference: response_time = '//real_text(loop%response_time)//' s'//new_line('a')
   end subroutine fm_table

   !> Note the CPU time and the wall clock at point k (for --timings).
   subroutine mark(k)
      integer, intent(in) :: k
      call cpu_time(cpu(k))
      call system_clock(clock(k), clock_rate)
   end subroutine mark

   !> Seconds as text, e.g. 0.0123.
   function seconds(value) result(text)
      real, intent(in) :: value
      character(len=:), allocatable :: text
      character(len=24) :: buffer
      write (buffer, '(f12.4)') value
      text = trim(adjustl(buffer))
   end function seconds

   !> Command argument i, whatever its length.
   subroutine get_argument(i, value)
      integer, intent(in) :: i
      character(len=:), allocatable, intent(out) :: value
      integer :: length, status
      call get_command_argument(i, length=length, status=status)
      if (status > 0) call fail(1, 'cannot read the command line')
      allocate (character(len=length) :: value)
      if (length > 0) call get_command_argument(i, value, status=status)
      if (status /= 0) call fail(1, 'cannot read the command line')
   end subroutine get_argument

   !> Refuse a path longer than the configuration can hold (never cut it).
   subroutine check_path_length(path, what)
      character(len=*), intent(in) :: path
      character(len=*), intent(in) :: what
      character(len=80) :: numbers
      if (len(path) <= path_len) return
      write (numbers, '(a,i0,a,i0)') ' is ', len(path), ' characters long; tmafm accepts at most ', path_len
      call fail(1, 'the '//what//' '''//shortened(path)//''''//trim(numbers))
   end subroutine check_path_length

   !> Text for a message: cut in the middle past 100 characters.
   function shortened(text) result(short)
      character(len=*), intent(in) :: text
      character(len=:), allocatable :: short
      if (len(text) <= 100) then
         short = text
      else
         short = text(1:40)//'...'//text(len(text) - 56:)
      end if
   end function shortened

   subroutine fail(code, message)
      integer, intent(in) :: code
      character(len=*), intent(in) :: message
      write (error_unit, '(a)') 'tmafm: error: '//printable_text(trim(message))
      stop code, quiet=.true.
   end subroutine fail

   !> Write text to standard output (file descriptor 1, unbuffered): a failed write (a full
   !> disk, a closed pipe) is exit 3 with one line, where Fortran's buffered unit lost it.
   subroutine print_stdout(text, what)
      character(len=*), intent(in) :: text
      character(len=*), intent(in) :: what
      integer :: status
      status = write_text(1, text)
      if (status < 0) call fail(3, 'cannot write '//what//' to standard output: '//error_text(status))
   end subroutine print_stdout

   !> The --help text, one new line after each line.
   function help_text() result(text)
      character(len=:), allocatable :: text
      character(len=*), parameter :: lines(*) = [character(len=88) :: &
         'usage: tmafm INPUT.nml [-o FILE] [-q] [--timings]', &
         '', &
         'Run the tapping-mode AFM model described by the namelist file INPUT.nml and', &
         'write the sampled trajectory (columns tau vt vtdot contact a_1..a_N adot_1..adot_N,', &
         'after # header lines that echo the fully resolved input).', &
         '', &
         '  -o, --output FILE   write to FILE instead of &output file; - is standard output', &
         '  -q, --quiet         no progress lines on stderr, no summary on stdout', &
         '      --timings       one line on stderr: CPU seconds of the run and of the write', &
         '  -h, --help          show this help', &
         '  -V, --version       show the version', &
         '', &
         'A file is replaced only when complete (written to a temporary, then renamed); a', &
         'device or FIFO is written directly.  &output format = ''npy'' writes a .npz archive', &
         '(the name must end in .npz) for numpy.load.', &
         '', &
         'Groups: &model &scene (or &physical, SI units) &initial &solver &output; with', &
         '&physical, &scan (an AM scan line) or &fm (an FM approach) writes their table.', &
         'Exit status: 0 ok, 1 usage, 2 bad input, 3 file error, 4 blow-up, 5 run failure.']
      integer :: k
      text = ''
      do k = 1, size(lines)
         text = text//trim(lines(k))//new_line('a')
      end do
   end function help_text

end program tmafm_main
