!> The namelist syntax, without meaning: namelist text held in memory becomes a document of
!> groups, each a list of `key = values` entries, with every value classified by what it looks
!> like (integer, real, logical, quoted string, unquoted word, or not a value at all).
!>
!> Groups are `&name ... /` (or `$name ... $end`, `&name ... &end`), found wherever they start,
!> several per line; `!` starts a comment outside strings.  Values are separated by commas or
!> blanks and may span lines; `r*value` repeats a value.  Anything the grammar does not consume
!> (text outside a group, a group left open, `key` without `=`, `a0(2) =`, two commas in a row,
!> text glued to a closing quote, non-text bytes) is an error with its line number: this module
!> never skips input.  Which keys exist and what types they take is tmafm_namelist's business.
!>
!> A tmafm output file (first line `# tmafm <version>`) is read through its header: the `# `
!> prefixes are dropped, lines of the header outside any group (version, input, counters) are
!> skipped, and reading stops at `# columns:` or at the first line not starting with `#`.
module tmafm_nml_syntax
   use tmafm_errors, only: ok, err_input
   use tmafm_text, only: lower, int_text
   implicit none
   private

   public :: nml_document_t, nml_group_t, nml_entry_t, nml_value_t, parse_namelist
   public :: value_integer, value_real, value_logical, value_string, value_word, value_other
   public :: value_kind_name, entry_text, entry_source, output_header_mark, patch_document

   !> A value that reads as an integer: [+-]digits.
   integer, parameter :: value_integer = 1
   !> A value that reads as a real: digits with a point and/or a d/e exponent, nan or inf.
   integer, parameter :: value_real = 2
   !> A logical: .true., .false., .t., .f., t or f.
   integer, parameter :: value_logical = 3
   !> A quoted string (' or ", a doubled quote inside stands for one).
   integer, parameter :: value_string = 4
   !> An unquoted word such as dopri5: not a value tmafm accepts anywhere.
   integer, parameter :: value_word = 5
   !> Anything else (5.0_8, out.dat, 3*): never accepted.
   integer, parameter :: value_other = 6
   !> The first characters of a tmafm output file, whose header is a namelist.
   character(len=*), parameter :: output_header_mark = '# tmafm '

   !> One value of an entry.
   type :: nml_value_t
      !> What the value looks like: one of the value_* constants.
      integer :: kind = value_other
      !> How many times it is repeated (r*value), 1 otherwise.
      integer :: repeat = 1
      !> The value as written (for strings: the contents, quotes removed, doubled quotes undone).
      character(len=:), allocatable :: text
      !> Why a value_other is not a value.
      character(len=:), allocatable :: problem
   end type nml_value_t

   !> One `key = values` entry of a group.
   type :: nml_entry_t
      !> The key in lower case.
      character(len=:), allocatable :: key
      !> Line of the key.
      integer :: line = 0
      !> The values as written (blanks and line ends collapsed), for messages: cut after
      !> max_written characters, so never read again as values (entry_source is).
      character(len=:), allocatable :: written
      !> The input text from the first value's first character to the last value's last one,
      !> verbatim (separators, line ends and comments between values included): read again, it
      !> gives the same values.
      character(len=:), allocatable :: source
      !> The values in order.
      type(nml_value_t), allocatable :: values(:)
      !> .true. for an entry that overrides a base input (patch_document): messages name it as
      !> an override, not by a line.
      logical :: override = .false.
   end type nml_entry_t

   !> One namelist group.
   type :: nml_group_t
      !> The group name in lower case.
      character(len=:), allocatable :: name
      !> Line of the group name.
      integer :: line = 0
      !> Number of entries in use.
      integer :: n_entries = 0
      !> The entries, in order (the first n_entries are in use).
      type(nml_entry_t), allocatable :: entries(:)
   end type nml_group_t

   !> A parsed namelist text.
   type :: nml_document_t
      !> Number of groups in use.
      integer :: n_groups = 0
      !> The groups, in order (the first n_groups are in use).
      type(nml_group_t), allocatable :: groups(:)
      !> .true. when the text was a tmafm output file read through its header.
      logical :: from_output_file = .false.
   end type nml_document_t

   !> Scanner state: the text, the position and the line (owned by one parse call).
   type :: scanner_t
      character(len=:), allocatable :: text
      integer :: p = 1
      integer :: line = 1
      logical :: skip_outside = .false.
   end type scanner_t

   !> Blanks between tokens: space and tab.  A CR counts only right before a LF (a CRLF line
   !> end); a lone CR or a form feed is refused with its line and column.
   character(len=*), parameter :: blank_chars = ' '//achar(9)
   !> What ends an unquoted token besides blanks and the line end.
   character(len=*), parameter :: cr = achar(13)
   character(len=*), parameter :: letters = 'abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ'
   character(len=*), parameter :: digits = '0123456789'
   !> Longest value text kept for messages.
   integer, parameter :: max_written = 100

contains

   !> Parse namelist `text` (lines separated by new_line('a')) into `doc`.  On error, ierr =
   !> err_input and errmsg = '<label>: <what>' with a line number; doc is then incomplete.
   subroutine parse_namelist(text, label, doc, ierr, errmsg)
      character(len=*), intent(in) :: text
      character(len=*), intent(in) :: label
      type(nml_document_t), intent(out) :: doc
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(scanner_t) :: s
      character(len=:), allocatable :: name
      integer :: nul

      ierr = ok
      errmsg = ''
      allocate (doc%groups(8))
      nul = index(text, achar(0))
      if (len(text) >= 2) then
         if (text(1:2) == char(255)//char(254) .or. text(1:2) == char(254)//char(255)) then
            call fail('the input is UTF-16 text (byte-order mark at its start): save it as '// &
                      'ASCII or UTF-8')
            return
         end if
      end if
      if (nul > 0) then
         call fail('line '//int_text(count_lines(text(1:nul)))//': a NUL byte: the input is '// &
                   'not a text file')
         return
      end if
      if (starts_with(text, output_header_mark)) then
         call output_header(text, s%text)
         s%skip_outside = .true.
         doc%from_output_file = .true.
      else
         s%text = text
         ! A UTF-8 byte-order mark is harmless: skip it.
         if (starts_with(text, char(239)//char(187)//char(191))) s%p = 4
      end if

      do
         call skip_blanks(s, ierr, errmsg, label)
         if (ierr /= ok) return
         if (s%p > len(s%text)) exit
         if (is_group_mark(s)) then
            call read_group_name(s, name)
            if (len(name) == 0) then
               call fail('line '//int_text(s%line)//': '''//s%text(s%p - 1:s%p - 1)// &
                         ''' without a group name')
               return
            end if
            if (name == 'end') then
               call fail('line '//int_text(s%line)//': &end outside a group')
               return
            end if
            call read_group(s, doc, name, label, ierr, errmsg)
            if (ierr /= ok) return
         else if (s%skip_outside) then
            call skip_line(s)
         else
            call fail('line '//int_text(s%line)//': text outside a group: '''// &
                      snippet(s%text, s%p)//''' (a group is &name key = value ... /; '// &
                      'comments start with !)')
            return
         end if
      end do
   contains
      subroutine fail(what)
         character(len=*), intent(in) :: what
         ierr = err_input
         errmsg = label//': '//what
      end subroutine fail
   end subroutine parse_namelist

   !> The header of an output file as namelist text: '# ' dropped, stop at '# columns:' or at
   !> the first line not starting with '#'.  Line numbers are kept.
   pure subroutine output_header(text, header)
      character(len=*), intent(in) :: text
      character(len=:), allocatable, intent(out) :: header
      character(len=:), allocatable :: buffer
      integer :: first, last, eol, used, skip

      allocate (character(len=len(text)) :: buffer)
      used = 0
      first = 1
      do while (first <= len(text))
         eol = index(text(first:), new_line('a'))
         if (eol == 0) then
            last = len(text)
         else
            last = first + eol - 2
         end if
         if (last < first) exit
         if (text(first:first) /= '#') exit
         if (starts_with(text(first:last), '# columns:')) exit
         skip = 1
         if (starts_with(text(first:last), '# ')) skip = 2
         buffer(used + 1:used + last - first + 2 - skip) = text(first + skip:last)//new_line('a')
         used = used + last - first + 2 - skip
         first = last + 2
      end do
      header = buffer(1:used)
   end subroutine output_header

   !> Parse the body of group `name` (its name already read) up to its closing '/'.
   subroutine read_group(s, doc, name, label, ierr, errmsg)
      type(scanner_t), intent(inout) :: s
      type(nml_document_t), intent(inout) :: doc
      character(len=*), intent(in) :: name
      character(len=*), intent(in) :: label
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(nml_group_t) :: group
      type(nml_entry_t) :: entry
      character(len=:), allocatable :: word, other
      integer :: start

      ierr = ok
      group%name = name
      group%line = s%line
      allocate (group%entries(8))
      do
         call skip_blanks(s, ierr, errmsg, label)
         if (ierr /= ok) return
         if (s%p > len(s%text)) then
            call fail('&'//name//' (line '//int_text(group%line)//') is not closed: end it with /')
            return
         end if
         if (s%text(s%p:s%p) == '/') then
            s%p = s%p + 1
            exit
         end if
         if (is_group_mark(s)) then
            start = s%line
            call read_group_name(s, other)
            if (other == 'end') exit
            call fail('&'//name//' (line '//int_text(group%line)//') is not closed before &'// &
                      other//' (line '//int_text(start)//'): end it with /')
            return
         end if
         if (verify(s%text(s%p:s%p), letters) /= 0) then
            call fail('line '//int_text(s%line)//': &'//name//': expected key = value, found '''// &
                      snippet(s%text, s%p)//'''')
            return
         end if
         start = s%p
         entry%line = s%line
         call read_identifier(s, word)
         call skip_blanks(s, ierr, errmsg, label)
         if (ierr /= ok) return
         if (s%p <= len(s%text)) then
            if (s%text(s%p:s%p) == '(') then
               call fail('line '//int_text(entry%line)//': &'//name//' '//word// &
                         '(...): indexed keys are not accepted; give the whole list: '//word// &
                         ' = v1, v2, ...')
               return
            end if
         end if
         if (s%p > len(s%text)) then
            call fail('&'//name//' (line '//int_text(group%line)//') is not closed: end it with /')
            return
         end if
         if (s%text(s%p:s%p) /= '=') then
            call fail('line '//int_text(entry%line)//': &'//name//': expected key = value, found '''// &
                      snippet(s%text, start)//'''')
            return
         end if
         s%p = s%p + 1
         entry%key = lower(word)
         call read_values(s, name, entry, label, ierr, errmsg)
         if (ierr /= ok) return
         call add_entry(group, entry)
      end do
      call add_group(doc, group)
   contains
      subroutine fail(what)
         character(len=*), intent(in) :: what
         ierr = err_input
         errmsg = label//': '//what
      end subroutine fail
   end subroutine read_group

   !> Read the values after `key =`, up to the next key, '/', a group mark or the end.
   subroutine read_values(s, group_name, entry, label, ierr, errmsg)
      type(scanner_t), intent(inout) :: s
      character(len=*), intent(in) :: group_name
      type(nml_entry_t), intent(inout) :: entry
      character(len=*), intent(in) :: label
      integer, intent(out) :: ierr
      character(len=*), intent(out) :: errmsg
      type(nml_value_t), allocatable :: values(:)
      type(nml_value_t) :: value
      character(len=:), allocatable :: token
      integer :: n, start, line, save_p, save_line, first, last
      logical :: need_value, after_comma
      character :: c

      ierr = ok
      n = 0
      first = 0
      last = -1
      allocate (values(4))
      entry%written = ''
      entry%source = ''
      need_value = .true.
      after_comma = .false.
      do
         call skip_blanks(s, ierr, errmsg, label)
         if (ierr /= ok) return
         if (s%p > len(s%text)) exit
         c = s%text(s%p:s%p)
         if (c == '/' .or. is_group_mark(s)) exit
         if (c == ',') then
            if (need_value) then
               if (n > 0) entry%written = entry%written//', ,'
               call fail('an empty value (a comma with no value before it): give every value')
               return
            end if
            need_value = .true.
            after_comma = .true.
            s%p = s%p + 1
            cycle
         end if
         if (c == '=') then
            call fail('an unexpected ''='' (a value is missing, or a key has no value)')
            return
         end if
         start = s%p
         line = s%line
         if (c == '''' .or. c == '"') then
            call read_string(s, value, ierr)
            if (ierr /= ok) then
               entry%written = join(entry%written, snippet(s%text, start))
               call fail('a string opened on line '//int_text(line)//' is not closed on that line')
               return
            end if
            if (s%p <= len(s%text)) then
               if (scan(s%text(s%p:s%p), blank_chars//cr//new_line('a')//',/!&$') == 0) then
                  entry%written = join(entry%written, s%text(start:s%p - 1))
                  call fail('text right after the closing quote: '''//snippet(s%text, s%p)// &
                            ''' (put a comma or a blank between values)')
                  return
               end if
            end if
         else
            save_p = s%p
            save_line = s%line
            call read_bare(s, token)
            if (is_identifier(token)) then
               ! `word =` or `word(` starts the next entry.
               call skip_blanks(s, ierr, errmsg, label)
               if (ierr /= ok) return
               if (s%p <= len(s%text)) then
                  if (scan(s%text(s%p:s%p), '=(') > 0) then
                     s%p = save_p
                     s%line = save_line
                     exit
                  end if
               end if
               s%p = save_p + len(token)
               s%line = save_line
            end if
            if (len(token) == 0) then
               call fail('an unexpected '''//c//'''')
               return
            end if
            if (verify(token, printable()) /= 0) then
               entry%written = join(entry%written, '(non-text bytes)')
               call fail('a non-text byte (code '//int_text(iachar(token(verify(token, printable()): &
                         verify(token, printable()))))//', column '// &
                         int_text(column_of(s%text, save_p + verify(token, printable()) - 1))// &
                         ') outside strings and comments')
               return
            end if
            value = classify(token)
         end if
         n = n + 1
         if (n > size(values)) call grow_values(values)
         values(n) = value
         if (n == 1) first = start
         last = s%p - 1
         if (len(entry%written) > max_written) then
            ! Long lists and strings: messages show their start only.
            if (.not. ends_with_dots(entry%written)) entry%written = entry%written//' ...'
         else if (n > 1 .and. after_comma) then
            entry%written = entry%written//', '//s%text(start:min(s%p - 1, start + max_written))
         else
            entry%written = join(entry%written, s%text(start:min(s%p - 1, start + max_written)))
         end if
         need_value = .false.
         after_comma = .false.
      end do
      if (n == 0) then
         call fail('no value given')
         return
      end if
      entry%values = values(1:n)
      entry%source = s%text(first:last)
   contains
      subroutine fail(what)
         character(len=*), intent(in) :: what
         ierr = err_input
         errmsg = label//': &'//group_name//' '//entry%key//' = '//entry%written//': '//what// &
                  ' (line '//int_text(s%line)//')'
      end subroutine fail
   end subroutine read_values

   !> Read a quoted string at s%p; ierr /= ok if it is not closed on its line.
   subroutine read_string(s, value, ierr)
      type(scanner_t), intent(inout) :: s
      type(nml_value_t), intent(out) :: value
      integer, intent(out) :: ierr
      character :: quote
      character(len=:), allocatable :: contents
      integer :: q, n, eol, last

      ierr = err_input
      quote = s%text(s%p:s%p)
      eol = index(s%text(s%p:), new_line('a'))
      if (eol == 0) then
         last = len(s%text)
      else
         last = s%p + eol - 2
      end if
      allocate (character(len=max(last - s%p, 0)) :: contents)
      n = 0
      q = s%p + 1
      do while (q <= last)
         if (s%text(q:q) == quote) then
            if (q < last) then
               if (s%text(q + 1:q + 1) == quote) then
                  n = n + 1
                  contents(n:n) = quote
                  q = q + 2
                  cycle
               end if
            end if
            value%kind = value_string
            value%text = contents(1:n)
            s%p = q + 1
            ierr = ok
            return
         end if
         n = n + 1
         contents(n:n) = s%text(q:q)
         q = q + 1
      end do
   end subroutine read_string

   !> Read an unquoted token: everything up to a blank, line end, ',', '/', '!', '&', '$', '='
   !> or a quote.
   subroutine read_bare(s, token)
      type(scanner_t), intent(inout) :: s
      character(len=:), allocatable, intent(out) :: token
      integer :: stop
      stop = scan(s%text(s%p:), blank_chars//cr//new_line('a')//',/!&$=''"')
      if (stop == 0) then
         token = s%text(s%p:)
      else
         token = s%text(s%p:s%p + stop - 2)
      end if
      s%p = s%p + len(token)
   end subroutine read_bare

   !> What an unquoted token is.
   pure recursive function classify(token) result(value)
      character(len=*), intent(in) :: token
      type(nml_value_t) :: value
      character(len=len(token)) :: low
      integer :: star, iostat, repeat

      value%text = token
      value%kind = value_other
      star = index(token, '*')
      if (star > 0) then
         if (star == 1 .or. verify(token(1:star - 1), digits) /= 0) then
            value%problem = 'a repeat count r*value needs a positive integer r'
            return
         end if
         if (star == len(token)) then
            value%problem = 'r* with no value after it (null values are not accepted)'
            return
         end if
         read (token(1:star - 1), *, iostat=iostat) repeat
         if (iostat /= 0 .or. star > 8) then
            value%problem = 'the repeat count is too large'
            return
         end if
         value = classify(token(star + 1:))
         value%repeat = repeat
         if (repeat < 1) then
            value%kind = value_other
            value%problem = 'a repeat count r*value needs a positive integer r'
         end if
         return
      end if
      low = lower(token)
      if (any(low == [character(len=7) :: '.true.', '.false.', '.t.', '.f.', 't', 'f'])) then
         value%kind = value_logical
      else if (is_special_real(low)) then
         value%kind = value_real
      else if (is_integer(low)) then
         value%kind = value_integer
      else if (is_real(low)) then
         value%kind = value_real
      else if (index(low, '_') > 1 .and. (is_integer(low(1:index(low, '_') - 1)) .or. &
                                          is_real(low(1:index(low, '_') - 1)))) then
         value%problem = 'kind suffixes such as _8 are not accepted: write '// &
                         token(1:index(low, '_') - 1)
      else if (is_identifier(token)) then
         value%kind = value_word
      else
         value%problem = 'not a number, a logical or a quoted string'
      end if
   end function classify

   pure logical function is_identifier(token)
      character(len=*), intent(in) :: token
      is_identifier = .false.
      if (len(token) == 0) return
      if (verify(token(1:1), letters) /= 0) return
      is_identifier = verify(token, letters//digits//'_') == 0
   end function is_identifier

   pure logical function is_integer(token)
      character(len=*), intent(in) :: token
      integer :: first
      first = 1
      if (len(token) > 0) then
         if (scan(token(1:1), '+-') > 0) first = 2
      end if
      is_integer = len(token) >= first .and. verify(token(first:), digits) == 0
   end function is_integer

   !> [+-] (d+[.d*] | .d+) [(e|d)[+-]d+], lower case.
   pure logical function is_real(token)
      character(len=*), intent(in) :: token
      integer :: p, n_mantissa, exponent_at
      is_real = .false.
      p = 1
      if (len(token) == 0) return
      if (scan(token(1:1), '+-') > 0) p = 2
      exponent_at = scan(token, 'ed')
      if (exponent_at == 0) exponent_at = len(token) + 1
      if (exponent_at <= p) return
      ! Mantissa: digits with at most one point, at least one digit.
      n_mantissa = exponent_at - p
      if (verify(token(p:exponent_at - 1), digits//'.') /= 0) return
      if (count_char(token(p:exponent_at - 1), '.') > 1) return
      if (count_char(token(p:exponent_at - 1), '.') == n_mantissa) return
      if (exponent_at > len(token)) then
         is_real = index(token, '.') > 0
         return
      end if
      is_real = is_integer(token(exponent_at + 1:))
   end function is_real

   pure logical function is_special_real(token)
      character(len=*), intent(in) :: token
      integer :: p
      p = 1
      if (len(token) > 0) then
         if (scan(token(1:1), '+-') > 0) p = 2
      end if
      is_special_real = .false.
      if (p > len(token)) return
      is_special_real = any(token(p:) == [character(len=8) :: 'nan', 'inf', 'infinity'])
   end function is_special_real

   pure integer function count_char(text, c)
      character(len=*), intent(in) :: text
      character, intent(in) :: c
      integer :: i
      count_char = 0
      do i = 1, len(text)
         if (text(i:i) == c) count_char = count_char + 1
      end do
   end function count_char

   !> A short name of a value kind, for messages ('an integer', 'a quoted string', ...).
   pure function value_kind_name(kind) result(name)
      integer, intent(in) :: kind
      character(len=len_trim(kind_name_padded(kind))) :: name
      name = kind_name_padded(kind)
   end function value_kind_name

   !> value_kind_name blank-padded to 16 characters.  (The text functions of this module give
   !> their results a length computed from the arguments, never a deferred length: see
   !> tmafm_text.)
   pure function kind_name_padded(kind) result(name)
      integer, intent(in) :: kind
      character(len=16) :: name
      select case (kind)
      case (value_integer)
         name = 'an integer'
      case (value_real)
         name = 'a real number'
      case (value_logical)
         name = 'a logical'
      case (value_string)
         name = 'a quoted string'
      case (value_word)
         name = 'an unquoted word'
      case default
         name = 'not a value'
      end select
   end function kind_name_padded

   !> `key = values` of an entry as written, for messages.
   pure function entry_text(entry) result(text)
      type(nml_entry_t), intent(in) :: entry
      character(len=len(entry%key) + 3 + len(entry%written)) :: text
      text = entry%key//' = '//entry%written
   end function entry_text

   !> `key = values` of an entry exactly as the input has it (values verbatim, never cut), to
   !> be read again: tmafm_api rebuilds a patched input from these.
   pure function entry_source(entry) result(text)
      type(nml_entry_t), intent(in) :: entry
      character(len=len(entry%key) + 3 + len(entry%source)) :: text
      text = entry%key//' = '//entry%source
   end function entry_source

   !> `base` patched key by key by `over` into `merged`: each group of `base` keeps its
   !> entries (with their lines) but those `over` sets in the same group, followed by `over`'s
   !> entries, marked as overrides; groups only `over` has come last (line 0).  The documents
   !> are merged, not their texts, so that a message names a base entry by its own line and
   !> an override as such (tmafm_api config_from_texts).
   subroutine patch_document(base, over, merged)
      type(nml_document_t), intent(in) :: base
      type(nml_document_t), intent(in) :: over
      type(nml_document_t), intent(out) :: merged
      logical :: used(over%n_groups)
      integer :: g, h, e, k

      allocate (merged%groups(max(8, base%n_groups + over%n_groups)))
      merged%from_output_file = base%from_output_file
      used = .false.
      do g = 1, base%n_groups
         associate (b => base%groups(g))
            h = 0
            do k = 1, over%n_groups
               if (over%groups(k)%name == b%name) h = k
            end do
            block
               type(nml_group_t) :: group
               group%name = b%name
               group%line = b%line
               allocate (group%entries(max(8, b%n_entries + 8)))
               do e = 1, b%n_entries
                  if (h > 0) then
                     if (any([(over%groups(h)%entries(k)%key == b%entries(e)%key, &
                               k = 1, over%groups(h)%n_entries)])) cycle
                  end if
                  call add_entry(group, b%entries(e))
               end do
               if (h > 0) then
                  used(h) = .true.
                  call add_overrides(group, over%groups(h))
               end if
               call add_group(merged, group)
            end block
         end associate
      end do
      do h = 1, over%n_groups
         if (used(h)) cycle
         block
            type(nml_group_t) :: group
            group%name = over%groups(h)%name
            group%line = 0
            allocate (group%entries(max(8, over%groups(h)%n_entries)))
            call add_overrides(group, over%groups(h))
            call add_group(merged, group)
         end block
      end do
   contains
      subroutine add_overrides(group, from)
         type(nml_group_t), intent(inout) :: group
         type(nml_group_t), intent(in) :: from
         type(nml_entry_t) :: entry
         integer :: j
         do j = 1, from%n_entries
            entry = from%entries(j)
            entry%override = .true.
            call add_entry(group, entry)
         end do
      end subroutine add_overrides
   end subroutine patch_document

   ! --- scanning helpers -------------------------------------------------------------------

   !> Skip blanks, line ends and comments; a non-text byte in a comment is fine, a NUL never
   !> gets here (parse_namelist refuses it first).
   subroutine skip_blanks(s, ierr, errmsg, label)
      type(scanner_t), intent(inout) :: s
      integer, intent(out) :: ierr
      character(len=*), intent(inout) :: errmsg
      character(len=*), intent(in) :: label
      character :: c
      ierr = ok
      do while (s%p <= len(s%text))
         c = s%text(s%p:s%p)
         if (c == new_line('a')) then
            s%line = s%line + 1
            s%p = s%p + 1
         else if (index(blank_chars, c) > 0) then
            s%p = s%p + 1
         else if (c == cr) then
            if (s%p == len(s%text)) then
               call refuse('a carriage return (code 13) not followed by a line feed: line ends '// &
                           'must be LF or CRLF')
               return
            else if (s%text(s%p + 1:s%p + 1) /= new_line('a')) then
               call refuse('a carriage return (code 13) not followed by a line feed: line ends '// &
                           'must be LF or CRLF')
               return
            end if
            s%p = s%p + 1
         else if (c == '!') then
            call skip_line(s)
         else if (c == achar(12)) then
            call refuse('a form feed (code 12) outside strings and comments: the input must be text')
            return
         else if (iachar(c) < 32 .or. iachar(c) > 126) then
            call refuse('a non-text byte (code '//int_text(iachar(c))//') outside strings and '// &
                        'comments: the input must be text')
            return
         else
            return
         end if
      end do
   contains
      subroutine refuse(what)
         character(len=*), intent(in) :: what
         ierr = err_input
         errmsg = label//': line '//int_text(s%line)//', column '//int_text(column_of(s%text, s%p))// &
                  ': '//what
      end subroutine refuse
   end subroutine skip_blanks

   !> Column (1 = first character) of position p of `text` in its line.
   pure integer function column_of(text, p)
      character(len=*), intent(in) :: text
      integer, intent(in) :: p
      column_of = p - index(text(1:p - 1), new_line('a'), back=.true.)
   end function column_of

   !> Move to the start of the next line.
   subroutine skip_line(s)
      type(scanner_t), intent(inout) :: s
      integer :: eol
      eol = index(s%text(s%p:), new_line('a'))
      if (eol == 0) then
         s%p = len(s%text) + 1
      else
         s%p = s%p + eol
         s%line = s%line + 1
      end if
   end subroutine skip_line

   logical function is_group_mark(s)
      type(scanner_t), intent(in) :: s
      is_group_mark = s%text(s%p:s%p) == '&' .or. s%text(s%p:s%p) == '$'
   end function is_group_mark

   !> Read '&name' or '$name' at s%p; name is lower case ('' when none follows).
   subroutine read_group_name(s, name)
      type(scanner_t), intent(inout) :: s
      character(len=:), allocatable, intent(out) :: name
      s%p = s%p + 1
      name = ''
      if (s%p > len(s%text)) return
      if (verify(s%text(s%p:s%p), letters) /= 0) return
      call read_identifier(s, name)
      name = lower(name)
   end subroutine read_group_name

   subroutine read_identifier(s, word)
      type(scanner_t), intent(inout) :: s
      character(len=:), allocatable, intent(out) :: word
      integer :: stop
      stop = verify(s%text(s%p:), letters//digits//'_')
      if (stop == 0) then
         word = s%text(s%p:)
      else
         word = s%text(s%p:s%p + stop - 2)
      end if
      s%p = s%p + len(word)
   end subroutine read_identifier

   !> Up to 40 characters of text from position p to the end of its line.
   pure function snippet(text, p) result(piece)
      character(len=*), intent(in) :: text
      integer, intent(in) :: p
      character(len=len_trim(snippet_padded(text, p))) :: piece
      piece = snippet_padded(text, p)
   end function snippet

   !> snippet blank-padded to 40 characters.
   pure function snippet_padded(text, p) result(piece)
      character(len=*), intent(in) :: text
      integer, intent(in) :: p
      character(len=40) :: piece
      integer :: eol, last
      eol = index(text(p:), new_line('a'))
      last = len(text)
      if (eol > 0) last = p + eol - 2
      last = min(last, p + 39)
      piece = text(p:last)
      if (verify(trim(piece), printable()) /= 0) piece = '(non-text bytes)'
   end function snippet_padded

   !> Every printable ASCII character.
   pure function printable() result(chars)
      character(len=95) :: chars
      integer :: i
      do i = 32, 126
         chars(i - 31:i - 31) = achar(i)
      end do
   end function printable

   pure function join(a, b) result(c)
      character(len=*), intent(in) :: a
      character(len=*), intent(in) :: b
      character(len=merge(len(b), len(a) + 1 + len(b), len(a) == 0)) :: c
      if (len(a) == 0) then
         c = b
      else
         c = a//' '//b
      end if
   end function join

   pure logical function ends_with_dots(text)
      character(len=*), intent(in) :: text
      ends_with_dots = .false.
      if (len(text) < 4) return
      ends_with_dots = text(len(text) - 3:) == ' ...'
   end function ends_with_dots

   pure logical function starts_with(text, head)
      character(len=*), intent(in) :: text
      character(len=*), intent(in) :: head
      starts_with = .false.
      if (len(text) < len(head)) return
      starts_with = text(1:len(head)) == head
   end function starts_with

   pure integer function count_lines(text)
      character(len=*), intent(in) :: text
      count_lines = count_char(text, new_line('a')) + 1
   end function count_lines

   subroutine grow_values(values)
      type(nml_value_t), allocatable, intent(inout) :: values(:)
      type(nml_value_t), allocatable :: bigger(:)
      integer :: k
      allocate (bigger(2*size(values)))
      do k = 1, size(values)
         bigger(k) = values(k)
      end do
      call move_alloc(bigger, values)
   end subroutine grow_values

   subroutine add_entry(group, entry)
      type(nml_group_t), intent(inout) :: group
      type(nml_entry_t), intent(in) :: entry
      type(nml_entry_t), allocatable :: bigger(:)
      integer :: k
      if (group%n_entries == size(group%entries)) then
         allocate (bigger(2*size(group%entries)))
         do k = 1, group%n_entries
            bigger(k) = group%entries(k)
         end do
         call move_alloc(bigger, group%entries)
      end if
      group%n_entries = group%n_entries + 1
      group%entries(group%n_entries) = entry
   end subroutine add_entry

   subroutine add_group(doc, group)
      type(nml_document_t), intent(inout) :: doc
      type(nml_group_t), intent(in) :: group
      type(nml_group_t), allocatable :: bigger(:)
      integer :: k
      if (doc%n_groups == size(doc%groups)) then
         allocate (bigger(2*size(doc%groups)))
         do k = 1, doc%n_groups
            bigger(k) = doc%groups(k)
         end do
         call move_alloc(bigger, doc%groups)
      end if
      doc%n_groups = doc%n_groups + 1
      doc%groups(doc%n_groups) = group
   end subroutine add_group

end module tmafm_nml_syntax
