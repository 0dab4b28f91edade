"""The strict reader: inputs that Fortran's own namelist read silently misread (or crashed on)
are refused with exit 2 (3 for file problems), exactly one `tmafm: error:` line that names the
group, the key and the value as written, and no output file.  Each case here ran silently (or
crashed) with `read(nml=)`."""

import os
import re
import select
import subprocess

import pytest

INPUT_ERROR, FILE_ERROR = 2, 3

# name: (bytes or text of the whole input file, words the one error line must contain, exit code)
CASES = {
    # A wrong-typed or unquoted value in the last key of the last group.
    "real_key_string": ("&solver tau_end = '5' /\n", ["&solver tau_end = '5':", "number"], INPUT_ERROR),
    "real_key_logical": ("&solver tau_end = .true. /\n", ["&solver tau_end = .true.:", "logical"],
                         INPUT_ERROR),
    "integer_key_string": ("&model n_modes = '3' /\n", ["&model n_modes = '3':", "integer"], INPUT_ERROR),
    "integer_key_real": ("&model n_modes = 3.0 /\n", ["&model n_modes = 3.0:", "integer"], INPUT_ERROR),
    "integer_key_logical": ("&model n_modes = .true. /\n", ["n_modes = .true.:", "integer"], INPUT_ERROR),
    "unquoted_method": ("&solver method = dopri5 /\n", ["&solver method = dopri5:", "quoted",
                                                          "'dopri5'"], INPUT_ERROR),
    "unquoted_convention": ("&model convention = consistent /\n",
                            ["&model convention = consistent:", "quoted"], INPUT_ERROR),
    "unquoted_law_only_entry": ("&model contact_law = dmt /\n", ["&model contact_law = dmt:", "quoted"],
                                INPUT_ERROR),
    # Two values for a scalar, kind suffixes.
    "scalar_two_values": ("&solver tau_end = 5 6 /\n", ["&solver tau_end = 5 6:", "one value"],
                          INPUT_ERROR),
    "kind_suffix": ("&solver tau_end = 5.0_8 /\n", ["&solver tau_end = 5.0_8:", "kind suffix"],
                    INPUT_ERROR),
    # A NaN among the initial values is a value, not "no values given".
    "nan_in_a0": ("&initial a0 = nan, 0, 0, 0 /\n", ["&initial a0 = nan, 0, 0, 0:", "finite"],
                  INPUT_ERROR),
    "nan_in_adot0": ("&initial adot0 = 0, NaN, 0, 0 /\n", ["&initial adot0 =", "value 2", "finite"],
                     INPUT_ERROR),
    # A string longer than its buffer is refused, not cut.
    "long_string": ("&model contact_law = 'hertz" + " " * 70 + "junk' /\n",
                    ["&model contact_law = 'hertz", "more than the 64 allowed"], INPUT_ERROR),
    "long_path": ("&output file = '" + "d/" * 520 + "x.dat' /\n",
                  ["&output file = '", "more than the 1024 allowed"], INPUT_ERROR),
    # Groups after a '/' on the same line are seen.
    "unknown_group_same_line": ("&model n_modes = 2 / &bogus x = 1 /\n", ["&bogus", "unknown namelist group"],
                                INPUT_ERROR),
    "repeated_group_same_line": ("&model n_modes = 2 / &model n_modes = 3 /\n", ["&model", "twice"],
                                 INPUT_ERROR),
    "repeated_key": ("&model n_modes = 2, n_modes = 3 /\n", ["&model n_modes = 3:", "twice"], INPUT_ERROR),
    "text_after_group": ("&model n_modes = 2 / tau_end = 5\n", ["text outside a group", "tau_end = 5"],
                         INPUT_ERROR),
    "group_not_closed": ("&model n_modes = 2\n", ["&model", "not closed"], INPUT_ERROR),
    "glued_to_quote": ("&model contact_law = 'dmt'x /\n", ["contact_law = 'dmt'", "closing quote"],
                       INPUT_ERROR),
    "empty_list_value": ("&initial a0 = 1e-4,, 0, 0, 0 /\n", ["&initial a0", "empty value"], INPUT_ERROR),
    "indexed_key": ("&initial a0(2) = 1e-4 /\n", ["a0(", "whole list"], INPUT_ERROR),
    # A correction named twice is refused (it used to be folded silently into one).
    "errata_repeated": ("&model errata = 'E1,e1' /\n", ["&model errata = 'E1,e1':", "repeated",
                                                         "distinct"], INPUT_ERROR),
    # Control bytes quoted back in a message are escaped, so the error stays one printable line.
    "control_byte_in_string": ("&model contact_law = '\x07hertz' /\n",
                               ["&model contact_law = '\\x07hertz':"], INPUT_ERROR),
    # Not text, or no group at all.
    "utf16": ("&model n_modes = 2 /\n".encode("utf-16"), ["UTF-16"], INPUT_ERROR),
    "random_bytes": (bytes((k * 151 + 7) % 256 for k in range(2000)), ["not a text file"], INPUT_ERROR),
    "high_bytes_outside_strings": ("&model n_modes = 2 / \u00e9\n".encode(), ["non-text byte"], INPUT_ERROR),
    "no_groups": ("just some words\n", ["text outside a group"], INPUT_ERROR),
    "empty_file": ("", ["no namelist group"], INPUT_ERROR),
    "only_comments": ("! nothing here\n\n", ["no namelist group"], INPUT_ERROR),
    # Wrong type named by its key, not by the next group.
    "wrong_type_names_key": ("&model n_modes = 'four' /\n&output file = 'x.dat' /\n",
                             ["&model n_modes = 'four':"], INPUT_ERROR),
    # Sample counts: no integer overflow, a bounded count and memory.  (The automatic-N
    # comparison runs no longer take the output's sample_dtau: their own grid has at most 2^20
    # intervals, within these limits; test_auto_modes_grid.py runs the input refused here before.)
    "sample_count_overflow": ("&solver tau_end = 1 /\n&output sample_dtau = 1e-10 /\n",
                              ["sample_dtau", "samples, more than 50000000"], INPUT_ERROR),
    "sample_memory": ("&model n_modes = 30 /\n&solver tau_end = 1e5, method = 'dopri5' /\n"
                      "&output sample_dtau = 1e-2 /\n", ["sample_dtau", "2 GiB"], INPUT_ERROR),
    # Derived groups of Eq. (12) checked before the run, naming the input to change.
    "physical_gives_infinite_group": ("&physical youngs_modulus_tip = 1e-300 /\n",
                                      ["&physical youngs_modulus_tip = 1e-300 gives", "Eq. (12)"],
                                      INPUT_ERROR),
    "physical_gives_huge_alpha1": ("&physical tip_mass = 1.0 /\n",
                                   ["&physical tip_mass = 1.0 gives alpha1", "<= 1.0E+003"], INPUT_ERROR),
    # Fixed-step methods: the worst-case step count against max_steps, up front.
    "fixed_step_hang": ("&solver method = 'rk4_paper', dtau = 1.5e-79 /\n",
                        ["&solver dtau = 1.5E-079", "1.07E+082 steps", "max_steps = 100000000"],
                        INPUT_ERROR),
    "max_steps_budget": ("&solver method = 'rk4_event', dtau = 1e-3, tau_end = 10, max_steps = 1000 /\n",
                         ["&solver dtau = 1.0E-003", "may need 1.60E+005 steps", "max_steps = 1000"],
                         INPUT_ERROR),
    "max_steps_range": ("&solver max_steps = 0 /\n", ["&solver max_steps = 0:", "1..1000000000000"],
                        INPUT_ERROR),
    "max_steps_real": ("&solver max_steps = 1e8 /\n", ["&solver max_steps = 1e8:", "integer"], INPUT_ERROR),
    "bad_format": ("&output format = 'xml' /\n", ["&output format = 'xml':", "'text' or 'npy'"], INPUT_ERROR),
    "unquoted_format": ("&output format = npy /\n", ["&output format = npy:", "quoted"], INPUT_ERROR),
    # Issue 18.  &model errata is 'convention', 'all', 'none' or a list of distinct known names
    # with no empty item and no blank: each of these ran, read leniently ('' and 'E1,,E4' as
    # lists with empty items dropped, 'none,E1' as E1, 'all,none' as all).
    "errata_empty": ("&model errata = '' /\n", ["&model errata = '':", "empty"], INPUT_ERROR),
    "errata_empty_item": ("&model errata = 'E1,,E4' /\n", ["&model errata = 'E1,,E4':", "empty item"],
                          INPUT_ERROR),
    "errata_trailing_comma": ("&model errata = 'E1,E4,' /\n", ["&model errata = 'E1,E4,':", "empty item"],
                              INPUT_ERROR),
    "errata_leading_comma": ("&model errata = ',E1' /\n", ["&model errata = ',E1':", "empty item"],
                             INPUT_ERROR),
    "errata_none_in_list": ("&model errata = 'none,E1' /\n", ["&model errata = 'none,E1':", "'none'",
                                                              "inside a list"], INPUT_ERROR),
    "errata_all_in_list": ("&model errata = 'all,none' /\n", ["&model errata = 'all,none':", "'all'",
                                                              "inside a list"], INPUT_ERROR),
    "errata_blank": ("&model errata = 'E1, E4' /\n", ["&model errata = 'E1, E4':", "blank"], INPUT_ERROR),
    "errata_e5": ("&model errata = 'E1,E5' /\n", ["&model errata = 'E1,E5':", "'E5'", "not a known"],
                  INPUT_ERROR),
    # A form feed or a lone carriage return outside strings was read as a blank.
    "form_feed": ("&model\fn_modes = 2 /\n", ["line 1, column 7", "form feed"], INPUT_ERROR),
    "form_feed_in_value": ("&solver tau_end = 5\f /\n", ["&solver tau_end", "code 12, column 20",
                                                          "(line 1)"], INPUT_ERROR),
    "lone_cr": ("&model n_modes = 2\r/\n", ["line 1, column 19", "carriage return"], INPUT_ERROR),
    "lone_cr_second_line": ("&model n_modes = 2 /\n&solver\rtau_end = 1 /\n",
                            ["line 2, column 8", "carriage return"], INPUT_ERROR),
    # Blanks inside a name were stripped: ' paper' ran as 'paper'.
    "blank_in_convention": ("&model convention = ' paper' /\n", ["&model convention = ' paper':", "blank"],
                            INPUT_ERROR),
    "blank_in_method": ("&solver method = 'dopri5 ' /\n", ["&solver method = 'dopri5 ':", "blank"],
                        INPUT_ERROR),
    "blank_in_law": ("&model contact_law = 'd mt' /\n", ["&model contact_law = 'd mt':", "blank"],
                     INPUT_ERROR),
    "blank_in_format": ("&output format = ' npy' /\n", ["&output format = ' npy':", "blank"], INPUT_ERROR),
    # '-' in a namelist wrote to standard output; standard output is the command line's -o -.
    "file_dash": ("&output file = '-' /\n", ["&output file = '-':", "ambiguous"], INPUT_ERROR),
    # A nonzero literal below the smallest normal double was read as 0 or as a subnormal.
    "underflow_to_zero": ("&scene alpha2 = 1e-400 /\n", ["&scene alpha2 = 1e-400:", "underflows to 0"],
                          INPUT_ERROR),
    "underflow_in_list": ("&initial a0 = 0, 2.5d-999, 0, 0 /\n", ["&initial a0 = 0, 2.5d-999, 0, 0:",
                                                                  "underflows to 0"], INPUT_ERROR),
    "subnormal": ("&solver atol = 1e-310 /\n", ["&solver atol = 1e-310:", "subnormal"], INPUT_ERROR),
    "overflow": ("&solver tau_end = 1e400 /\n", ["&solver tau_end = 1e400:", "overflows"], INPUT_ERROR),
}

#: Layouts and values that stay valid under the rules above (issue 18): each runs, and the
#: header echoes the value.
VALID = {
    "crlf_line_ends": ("&model n_modes = 2,\r\n  errata = 'E4,e1' /\r\n&solver tau_end = 0.5 /\r\n",
                       "#     errata = 'E1,E4'"),
    "errata_all_upper": ("&model errata = 'ALL' /\n&solver tau_end = 0.5 /\n",
                         "#     errata = 'E1,E2,E3,E4,E6,E7'"),
    "errata_none": ("&model errata = 'none', convention = 'consistent' /\n&solver tau_end = 0.5 /\n",
                    "#     errata = 'none'"),
    "zero_with_exponent": ("&initial a0 = 0.0e-999, 0, 0, 0 /\n&solver tau_end = 0.5 /\n",
                           "#     a0 = 0.0E+000, 0.0E+000, 0.0E+000, 0.0E+000"),
    "smallest_normal": ("&solver atol = 2.2250738585072014e-308, tau_end = 0.5 /\n",
                        "#     atol = 2.2250738585072014E-308"),
    "form_feed_in_comment": ("&model n_modes = 4 / ! a \f in a comment\n&solver tau_end = 0.5 /\n",
                             "#     n_modes = 4"),
}


def write_input(tmp_path, content):
    path = tmp_path / "in.nml"
    if isinstance(content, str):
        path.write_text(content)
    else:
        path.write_bytes(content)
    return path


@pytest.mark.parametrize("name", sorted(CASES))
def test_refused_with_one_line_naming_the_key(tmp_path, run_exe, name):
    content, words, code = CASES[name]
    proc = run_exe(write_input(tmp_path, content), "-o", "out.dat")
    assert proc.returncode == code, proc.stderr
    assert proc.stderr.startswith("tmafm: error: ") and proc.stderr.count("\n") == 1, proc.stderr
    for word in words:
        assert word in proc.stderr, (word, proc.stderr)
    # Exponents always keep their E (1.0E-300, never 1.00-300).
    assert not re.search(r"\d[+-]\d{3}\b", proc.stderr.replace("E+", "").replace("E-", "")), proc.stderr
    assert "Backtrace" not in proc.stderr and proc.stdout == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.nml"]


@pytest.mark.parametrize("name", sorted(VALID))
def test_still_valid(tmp_path, run_exe, name):
    content, line = VALID[name]
    proc = run_exe(write_input(tmp_path, content), "-q", "-o", "out.dat")
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    assert line in (tmp_path / "out.dat").read_text().splitlines()


def test_a_fifo_input_without_a_writer_says_that_it_waits(tmp_path, exe):
    """A FIFO nobody writes to hung without a word (issue 18): tmafm now says on stderr that it
    waits for input, and reads the input once it comes."""
    os.mkfifo(tmp_path / "in.nml")
    proc = subprocess.Popen([exe, "-q", "in.nml", "-o", "out.dat"], cwd=tmp_path, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        ready, _, _ = select.select([proc.stderr], [], [], 30)
        assert ready, "no line on stderr within 30 s: a silent hang"
        line = proc.stderr.readline()
        assert line == "tmafm: waiting for input: nothing has been written to the FIFO 'in.nml' yet\n"
        with open(tmp_path / "in.nml", "w") as writer:
            writer.write("&model n_modes = 2 /\n&solver tau_end = 0.5 /\n")
        out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0 and err == "" and out == "", err
    assert "#     n_modes = 2" in (tmp_path / "out.dat").read_text().splitlines()


def test_directory_as_input_is_a_file_error(tmp_path, run_exe):
    (tmp_path / "adir").mkdir()
    proc = run_exe("adir")
    assert proc.returncode == FILE_ERROR, proc.stderr
    assert proc.stderr == "tmafm: error: input file 'adir' is a directory\n"


def test_endless_input_is_refused(run_exe):
    proc = run_exe("/dev/zero")
    assert proc.returncode == INPUT_ERROR
    assert "larger than 1048576 bytes" in proc.stderr and proc.stderr.count("\n") == 1


def test_several_groups_per_line_and_dollar_groups_are_read(tmp_path, run_exe):
    path = tmp_path / "in.nml"
    path.write_text("&model n_modes = 2, contact_law = 'DMT' / &solver tau_end = 0.5, max_steps = 2000000 /"
                    " ! comment\n$output file = 'o.dat', sample_dtau = 0.25, format = 'TEXT' $end\n")
    proc = run_exe(path, "-q")
    assert proc.returncode == 0, proc.stderr
    header = (tmp_path / "o.dat").read_text()
    for line in ("#     n_modes = 2", "#     contact_law = 'dmt'", "#     tau_end = 5.0E-001",
                 "#     max_steps = 2000000", "#     sample_dtau = 2.5E-001", "#     format = 'text'"):
        assert line in header.splitlines(), line


def test_values_spanning_lines_repeats_and_exponents(tmp_path, run_exe):
    path = tmp_path / "in.nml"
    path.write_text("&model\n  n_modes = 4 /\n&initial\n  a0 = 1.5d-4,\n       2*0.0 ! two zeros\n"
                    "       -2E-5\n  adot0 = 4*0 /\n&solver tau_end = 1 /\n&output file = 'o.dat' /\n")
    proc = run_exe(path, "-q")
    assert proc.returncode == 0, proc.stderr
    assert "#     a0 = 1.5E-004, 0.0E+000, 0.0E+000, -2.0E-005" in (tmp_path / "o.dat").read_text()


@pytest.mark.parametrize("text, words", [
    ("&initial a0 = " + "0 " * 400000 + "/\n", ["&initial a0 = 0 0 0", "...: takes at most 30 values"]),
    ("&output file = '" + "x" * 900000 + "' /\n", ["&output file = 'xxx", "is 900000 characters long"]),
])
def test_large_inputs_end_in_one_short_line(tmp_path, run_exe, text, words):
    """Inputs near the 1 MiB limit are parsed in linear time; the message quotes their start."""
    proc = run_exe(write_input(tmp_path, text))
    assert proc.returncode == INPUT_ERROR
    assert proc.stderr.count("\n") == 1 and len(proc.stderr) < 400, proc.stderr[:400]
    for word in words:
        assert word in proc.stderr
