"""Check the numbers README.md and docs/ quote against what makes them; exit 1 on drift.

    /opt/tmafm-venv/bin/python benchmarks/check_docs.py               # the docs against the committed JSON
    /opt/tmafm-venv/bin/python benchmarks/check_docs.py --recompute   # + the cheap deterministic reruns (~20 s)
    /opt/tmafm-venv/bin/python benchmarks/check_docs.py --figures     # + `python -m tmafm.figures` rerun (~45 s CPU)
    /opt/tmafm-venv/bin/python benchmarks/check_docs.py --rerun-timings   # + run_time, basin_map, period_cost (~10 min)
    /opt/tmafm-venv/bin/python benchmarks/check_docs.py --only figures readme   # some groups (--list)

Each claim is a piece of the docs' text with slots for its numbers, the numbers formatted from
their source as the text prints them (digits, minus sign, thousands separator).  The text is
found with the slots matching any number, and the numbers it holds are compared with the
source's: "OK" or "DRIFT", one row per claim.  Sources:
- the committed JSON each command writes (docs/figures/summary.json for reproduction.md,
  benchmarks/*.json for README, performance.md, errata.md, observables.md, output-format.md
  and sweeps.md), and
  for the runs the docs call earlier, the JSON as committed then (`git show REV:FILE`);
- with --recompute, the deterministic numbers (classifications, periods, counts, V_T errors,
  row counts) computed again on this build: every flight_exact case of summary.json and the
  rk4_paper verdicts the docs quote, the V_T errors of the period_cost rows the docs quote,
  the Fig. 2 run's rows and counters, Fig. 6's single landing, Fig. 7 over 300 periods.  Each
  is compared with the committed JSON: labels and counts exactly, reals to 1e-6 relative (far
  above the flight_exact runs' own error and their change under a 1e-16 nudge of a1(0), 1e-7;
  far below the docs' 4 digits).  rk4_paper runs are compared by their labels only (a nudge
  of 1e-16 moves their reals by 2e-4); two of their quoted verdicts flip with such a nudge
  (RK4_FRAGILE), and for those the docs must name both labels, rerun with a1(0) nudged;
- with --figures, the documented command `python -m tmafm.figures --out TMP --periods 100
  --basin 41` is rerun, every case and the basin scan compared with the committed
  summary.json in the same way, and reproduction.md checked against the rerun;
- timings are never rerun by default (they move by over 1.6x on the shared VM); with
  --rerun-timings the three timed benchmarks README cites are rerun into a temporary folder
  and each quoted timing must lie within --timing-factor (1.6) of the committed one, while
  their deterministic numbers must agree exactly.
Every markdown table of docs/performance.md is checked row by row, or listed ("no source")
with the reason no JSON in the repository backs it.  tests/test_docs_claims.py runs the JSON
checks and --recompute without the two round-off verdicts (about 12 s of CPU).
"""

from __future__ import annotations

import argparse
import json
import math
import re
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
BENCH = REPO / "benchmarks"
STUDIES = REPO / "studies"


def result_path(name):
    """Path of a committed result by its name (e.g. 'run_time.json'): the timing benchmarks'
    results are in benchmarks/results/, the studies' in studies/results/ (studies/README.md)."""
    for folder in (BENCH / "results", STUDIES / "results"):
        if (folder / name).exists():
            return folder / name
    raise FileNotFoundError(f"{name}: in neither benchmarks/results/ nor studies/results/")
SUMMARY = REPO / "docs" / "figures" / "summary.json"
MINUS = "\u2212"
NUM = r"[\u2212-]?(?:\d{1,3}(?:[ ,]\d{3})+(?![\d])|\d+)(?:\.\d+)?(?:e[\u2212+-]?\d+)?"
SPAN = rf"{NUM}\u2013{NUM}"
WORD = r"[\w.\u2212-]+"


# ----------------------------------------------------------------------------- formatting
def sci(x, sig, minus=MINUS):
    """x with `sig` significant digits as the docs write it: -1.748e-4 (no exponent zeros)."""
    mantissa, exponent = f"{abs(x):.{sig - 1}e}".split("e")
    return f"{minus if x < 0 else ''}{mantissa}e{int(exponent)}"


def sig(x, n):
    """n significant digits in fixed notation (0.0010, 0.022, 1.7)."""
    decimals = max(0, n - 1 - math.floor(math.log10(abs(x))))
    return f"{x:.{decimals}f}"


def grouped(n, sep=" "):
    """An integer with thousands separators: 614,751 or 40 000."""
    return f"{int(round(n)):,}".replace(",", sep)


def bound(x, style="sci"):
    """The smallest one-digit number >= x: the docs' "to 5e-7" for 4.4e-7."""
    e = math.floor(math.log10(x))
    m = math.ceil(round(x / 10 ** e, 9))
    if m == 10:
        m, e = 1, e + 1
    return f"{m}e{e}" if style == "sci" else f"{m * 10.0 ** e:.{max(0, -e)}f}"


def common(values):
    """The one value all of `values` share, or a 'mixed' marker that matches no text."""
    values = list(values)
    return values[0] if all(v == values[0] for v in values) else "mixed:" + ",".join(values)


def span(values, fmt):
    """'lo–hi' of formatted extremes (the docs' en dash)."""
    return f"{fmt(min(values))}\u2013{fmt(max(values))}"


# ----------------------------------------------------------------------------- the checker
@dataclass
class Row:
    group: str
    where: str
    claim: str
    docs: str
    source: str
    ok: bool | None   # None: named, not checked
    labels: tuple = ("docs", "source")


class Checker:
    def __init__(self):
        self.rows: list[Row] = []
        self._text: dict[str, str] = {}

    def doc(self, name):
        if name not in self._text:
            self._text[name] = (REPO / name).read_text()
        return self._text[name]

    def _headings(self, name):
        """(offset, level, title) of each heading of a markdown file, fenced code skipped."""
        out, offset, fenced = [], 0, False
        for line in self.doc(name).splitlines(keepends=True):
            if line.startswith("```"):
                fenced = not fenced
            elif not fenced and (m := re.match(r"(#+) (.*)", line)):
                out.append((offset, len(m.group(1)), m.group(2).strip()))
            offset += len(line)
        return out

    def _section(self, name, heading):
        """The text under the first heading starting with `heading`, to the next at its level."""
        text = self.doc(name)
        if heading is None:
            return text, 0
        headings = self._headings(name)
        for i, (start, level, title) in enumerate(headings):
            if title.startswith(heading):
                end = next((o for o, lv, _ in headings[i + 1:] if lv <= level), len(text))
                return text[start:end], start
        raise LookupError(f"{name}: no heading starting {heading!r}")

    def text(self, group, doc, template, values, section=None):
        """The docs' `template` ('{}' for each number) holds `values` (as formatted)."""
        values = [str(v) for v in values]
        parts = template.split("{}")
        if len(parts) != len(values) + 1:
            raise ValueError(f"{template!r}: {len(parts) - 1} slots, {len(values)} values")
        regex = ""
        for i, part in enumerate(parts):
            regex += "".join(r"\s+" if piece.isspace() else re.escape(piece)
                             for piece in re.split(r"(\s+)", part) if piece)
            if i < len(values):
                regex += f"({next(p for p in (NUM, SPAN, WORD) if re.fullmatch(p, values[i]))})"
        body, offset = self._section(doc, section)
        matches = list(re.finditer(regex, body))
        claim = " ".join(template.split())
        claim = claim if len(claim) <= 70 else claim[:67] + "..."
        if not matches:
            self.rows.append(Row(group, doc, claim, "(text not found)", " | ".join(values), False))
            return False
        m = next((m for m in matches if list(m.groups()) == values), matches[0])
        line = self.doc(doc).count("\n", 0, offset + m.start()) + 1
        ok = list(m.groups()) == values
        self.rows.append(Row(group, f"{doc}:{line}", claim, " | ".join(m.groups()),
                             " | ".join(values), ok))
        return ok

    def row(self, group, doc, generated, key_cells, section=None):
        """A markdown table row of the docs equals `generated` (a row a script's own table
        function prints): its first `key_cells` cells find the row, the numbers after them are
        compared."""
        cells = generated.strip().strip("|").split("|")
        key = "|" + "|".join(cells[:key_cells]) + "|"
        rest = "|".join(cells[key_cells:]) + "|"
        values = re.findall(NUM, rest)
        template = re.sub(NUM, "{}", rest)
        return self.text(group, doc, key + template, values, section)

    def value(self, group, where, claim, docs, source, ok=None, labels=("docs", "source")):
        """A value compared directly (docs or committed JSON against its source or a rerun)."""
        ok = (str(docs) == str(source)) if ok is None else ok
        self.rows.append(Row(group, where, claim, str(docs), str(source), ok, labels))
        return ok

    def unchecked(self, group, where, claim, why):
        self.rows.append(Row(group, where, claim, why, "", None))

    def report(self, out=sys.stdout, verbose=True):
        drift = [r for r in self.rows if r.ok is False]
        width = max((len(r.where) for r in self.rows), default=10)
        for r in self.rows:
            if r.ok is False or verbose:
                status = {True: "OK", False: "DRIFT", None: "no source"}[r.ok]
                print(f"{status:9} {r.where:{width}}  {r.claim}", file=out)
                if r.ok is not None:
                    print(f"{'':9} {'':{width}}    {r.labels[0]}: {r.docs}   {r.labels[1]}: {r.source}", file=out)
                else:
                    print(f"{'':9} {'':{width}}    {r.docs}", file=out)
        checked = sum(r.ok is not None for r in self.rows)
        print(f"{checked} claims checked, {len(drift)} drifted; "
              f"{sum(r.ok is None for r in self.rows)} tables without a source", file=out)
        return not drift


def load(path):
    return json.loads(Path(path).read_text())


class NoHistory(LookupError):
    """The checkout has no git history to read an earlier run's JSON from."""


def git(*args):
    proc = subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True)
    if proc.returncode != 0:
        raise NoHistory(f"git {' '.join(args)}: {proc.stderr.strip()}")
    return proc.stdout


def committed(rev, path):
    """A file as committed at `rev` (the docs' "an earlier run at commit ..." numbers); a
    benchmarks/results/ file is read at its earlier place, benchmarks/, in older commits."""
    try:
        return json.loads(git("show", f"{rev}:{path}"))
    except NoHistory:
        if "/results/" not in path:
            raise
        return json.loads(git("show", f"{rev}:{path.replace('/results/', '/')}"))


def history(path):
    """The commits that changed a benchmarks/results/ file's content, newest first, before and
    after it moved there from benchmarks/ (the move itself, and merges that brought the same
    content again, are left out)."""
    revs, last = [], None
    for rev in git("log", "--format=%H", "--", path, path.replace("/results/", "/")).split():
        try:
            content = committed(rev, path)
        except NoHistory:   # the commit that deleted the file at one of its places
            continue
        if content != last:
            revs.append(rev)
            last = content
    return revs


def bench_module(name):
    """A benchmarks/ or studies/ script as a module (they import each other by bare name)."""
    for folder in (BENCH, STUDIES):
        if str(folder) not in sys.path:
            sys.path.append(str(folder))   # last: these names never shadow another module
    import importlib
    return importlib.import_module(name)


# ----------------------------------------------------------------------------- reproduction.md
def check_figures(ck, summary, group="figures"):
    """docs/reproduction.md against a summary.json (committed, or a rerun's)."""
    doc = "docs/reproduction.md"
    cases = summary["cases"]

    def case(name, method="flight_exact", convention="paper"):
        return cases[f"{name}/{method}/{convention}"]

    def t(template, values, section):
        ck.text(group, doc, template, values, section)

    fig2 = [f"fig2_n{n}" for n in (1, 2, 3, 4)]
    s2 = "Fig. 2:"
    t("Each run lasts at least {} drive periods", [summary["periods"]], None)
    t("`flight_exact`: located switches, error-controlled at rtol {}.",
      [sci(summary["methods"]["flight_exact"]["rtol"], 1)], None)
    t("- {} for `rk4_paper`, whose", [sci(case("fig3", "rk4_paper")["tolerance"], 1)], None)
    t("- {} for `flight_exact`.", [sci(case("fig3")["tolerance"], 1)], None)
    t("| min V_T | {} | {} | {} | {} |", [sci(case(n)["vt_min"], 4) for n in fig2], s2)
    t("| max V_T | {} | {} | {} | {} |", [sci(case(n)["vt_max"], 4) for n in fig2], s2)
    t("| contact fraction | {} | {} | {} | {} |", [f"{case(n)['contact_fraction']:.4f}" for n in fig2], s2)
    t("Every N gives a {} motion with {} contacts per period.",
      [common(case(n)["classification"] for n in fig2),
       common(f"{case(n)['contacts_per_period']:.0f}" for n in fig2)], s2)
    vmin = [abs(case(n)["vt_min"]) for n in fig2]
    pct = [100 * (vmin[i] - vmin[i + 1]) / vmin[i] for i in range(3)]
    t("The change in min V_T is {} % from N = 1 to 2, {} % from 2 to 3, and {} % from 3 to 4.",
      [f"{p:.0f}" if p >= 10 else f"{p:.1f}" for p in pct], s2)
    gap = max(abs(case(n, "rk4_paper")[k] - case(n)[k]) for n in fig2 for k in ("vt_min", "vt_max"))
    t("gives the same extremes to {}.", [bound(gap)], s2)
    t('N = 4 never settles below its tolerance ("{}")', [case("fig2_n4", "rk4_paper")["classification"]], s2)
    t('in `consistent` N = 2 comes out as "{}"',
      [case("fig2_n2", "rk4_paper", "consistent")["classification"]], s2)
    t("the located run is {} in every case",
      [common(case(n, "flight_exact", c)["classification"] for n in fig2 for c in ("paper", "consistent"))], s2)
    c4 = case("fig2_n4", convention="consistent")
    t("contact is deeper (min V_T = {} at N = 4) and longer (contact fraction {})",
      [sci(c4["vt_min"], 4), f"{c4['contact_fraction']:.3f}"], s2)
    t("The convergence in N is the same: {}, {}, {}, {}.",
      [sci(case(n, convention="consistent")["vt_min"], 4) for n in fig2], s2)
    t("| 2 | holds (both conventions): N ≥ 3 converged, contact about {} % ({} % in `consistent`)",
      [f"{100 * case('fig2_n4')['contact_fraction']:.0f}", f"{100 * c4['contact_fraction']:.0f}"], "Summary")

    # Fig. 3: the modal amplitudes of fig3, flight_exact
    s3 = "Fig. 3:"
    amps = case("fig3")["modal_amplitudes"]
    rk4 = case("fig3", "rk4_paper")["modal_amplitudes"]
    for phase in ("contact", "free"):
        for measure, label in (("max_abs", "max \\|a_j\\|"), ("half_peak_to_peak", "half peak-to-peak")):
            t(f"| {phase}, {label} | {{}} | {{}} | {{}} | {{}} |", [sci(x, 3) for x in amps[phase][measure]], s3)
    worst = max(abs(r / a - 1) for phase in ("contact", "free") for measure in ("max_abs", "half_peak_to_peak")
                for a, r in zip(amps[phase][measure], rk4[phase][measure]))
    t("`rk4_paper` agrees to {} %", [bound(100 * worst, "fixed")], s3)
    h = {p: amps[p]["half_peak_to_peak"] for p in ("contact", "free")}
    mx = {p: amps[p]["max_abs"] for p in ("contact", "free")}
    t("a3/a1 is {} in contact against {} out of contact (half peak-to-peak), and a4/a1 {} against {}.",
      [sig(h["contact"][2] / h["contact"][0], 2), sig(h["free"][2] / h["free"][0], 2),
       sig(h["contact"][3] / h["contact"][0], 2), sig(h["free"][3] / h["free"][0], 2)], s3)
    t("a2/a1 is {} (max) or {} (half peak-to-peak).",
      [sig(mx["contact"][1] / mx["contact"][0], 2), sig(h["contact"][1] / h["contact"][0], 2)], s3)
    t("it is {}× a1 in contact (half peak-to-peak; {}× by max |a_j|)",
      [sig(h["free"][0] / h["contact"][0], 2), sig(mx["free"][0] / mx["contact"][0], 2)], s3)

    # Figs. 4 and 5
    s45 = "Figs. 4 and 5:"
    four = ["fig4a", "fig4c", "fig5a", "fig5c"]
    t("all four initial conditions reach the same {} attractor, with min V_T = {}, contact "
      "fraction {}, and {} dissipated per period.",
      [common(case(n)["classification"] for n in four), common(sci(case(n)["vt_min"], 4) for n in four),
       common(f"{case(n)['contact_fraction']:.4f}" for n in four),
       common(sci(case(n)["dissipated_per_period"], 4) for n in four)], s45)
    t("`rk4_paper` also finds {}, with min V_T = {}.",
      [common(case(n, "rk4_paper")["classification"] for n in four),
       common(sci(case(n, "rk4_paper")["vt_min"], 4) for n in four)], s45)
    t("the steady state is reached at τ = {}, {}, {} and {}.",
      [f"{case(n)['steady_state']['tau']:.1f}" for n in four], s45)
    if "basin" in summary:
        basin = summary["basin"]
        t("{} values of a1(0) in [0, 1e-3], in both conventions.", [len(basin["a1_0"])], s45)
        t("Every one reaches a single {} attractor,",
          [common(a[0] if len(a) == 1 else "several" for a in basin["attractors"].values())], s45)
        t("with min V_T = {} in `paper` and {} in `consistent`.",
          [common(sci(r["vt_min"], 4) for r in basin["rows"][c]) for c in ("paper", "consistent")], s45)

    # Fig. 6
    s6 = "Fig. 6:"
    for method in ("flight_exact", "rk4_paper"):   # "(`paper`, both integrators)"
        c = case("fig6", method)
        t("After that, contact fraction {} and V_T ∈ [{}, {}].",
          [f"{c['contact_fraction']:.3f}", sci(c["vt_min"], 4), sci(c["vt_max"], 3)], s6)
    c = case("fig6")
    t("The motion is {} from τ = {} (flight_exact), with {} new contacts per period and {} dissipated per period.",
      [c["classification"], f"{c['steady_state']['tau']:.1f}", f"{c['contacts_per_period']:.0f}",
       sci(c["dissipated_per_period"], 4)], s6)
    t("max |a_j| in contact is {}, {}, {} and {}.",
      [sci(x, d) for x, d in zip(c["modal_amplitudes"]["contact"]["max_abs"], (3, 3, 2, 2))], s6)
    cc, rc = case("fig6", convention="consistent"), case("fig6", "rk4_paper", "consistent")
    t("It taps, with contact fraction {}, V_T up to {} and {} contacts per period. "
      "`flight_exact` finds {} from τ = {}.",
      [f"{cc['contact_fraction']:.3f}", sci(cc["vt_max"], 2), f"{cc['contacts_per_period']:.0f}",
       cc["classification"], f"{cc['steady_state']['tau']:.1f}"], s6)
    t('`rk4_paper` finds no period at its tolerance ("{}":', [rc["classification"]], s6)
    t("in `consistent` the tip taps ({})", [cc["classification"]], "Summary")

    # Fig. 7 (100 periods; the 300-period run is period_search's)
    s7 = "Fig. 7:"
    h, d = case("fig7_hertz"), case("fig7_dmt")
    t("min V_T is {} (DMT) against {} (Hertz), with contact fractions {} and {}.",
      [sci(d["vt_min"], 4), sci(h["vt_min"], 4), f"{d['contact_fraction']:.3f}", f"{h['contact_fraction']:.3f}"], s7)
    t("Over 100 periods, Hertz is {} with `flight_exact`. DMT is {} from τ = {}.",
      [h["classification"], d["classification"], f"{d['steady_state']['tau']:.1f}"], s7)
    t('`rk4_paper` over 100 periods gives "{}" for Hertz', [case("fig7_hertz", "rk4_paper")["classification"]], s7)
    t('for Hertz and "{}" for DMT', [case("fig7_dmt", "rk4_paper")["classification"]], s7)


def check_period_search(ck, search=None, group="period_search"):
    """reproduction.md's longer studies, from benchmarks/period_search.json."""
    search = search or load(result_path("period_search.json"))
    doc = "docs/reproduction.md"
    scan = search["scan"]
    ck.text(group, doc, "All {} runs are {}.",
            [len(scan), common(r["classification"] for r in scan)], "Figs. 4 and 5:")
    alphas = sorted({r["alpha2"] for r in scan})
    ck.text(group, doc, "α2 from {} to {} in steps of {},",
            [sci(alphas[0], 1), sci(alphas[-1], 1), sci(alphas[1] - alphas[0], 1)], "Figs. 4 and 5:")
    long = search["fig7"]["fig7_hertz/300"]
    ck.text(group, doc, "Hertz too settles to {}, from τ = {} ({} periods).",
            [long["classification"], f"{long['steady_tau']:.0f}", f"{long['steady_tau'] / math.pi:.0f}"], "Fig. 7:")


# ----------------------------------------------------------------------------- README
def _period_cost_rows(report):
    return {(scene, r["method"], r.get("rtol")): r for scene, e in report["scenes"].items() for r in e["rows"]}


#: README's "which method for what" table: (row of period_cost.json's fig2 scene, first cell,
#: second cell); the numbers of each row are its CPU per period and V_T error.
METHOD_ROWS = (
    (("flight_exact", 1e-7, None), "`flight_exact` rtol 1e-7 (observed runs' and sweeps' default)",
     "sweeps, approach and frequency curves, basin maps: anything run to a steady state"),
    (("flight_exact", 1e-10, None), "`flight_exact` rtol 1e-10, atol 1e-14",
     "reference runs, convergence studies"),
    (("dop853", 1e-7, None), "`dop853` rtol 1e-7",
     "a trajectory with a classical adaptive method, cross-checks"),
    (("dopri5", 1e-7, None), "`dopri5` rtol 1e-7", "the same at lower order; the automatic-N search"),
    (("rk4_event", None, 0.002), "`rk4_event` dτ = 2e-3", "fixed steps with located switches"),
    (("rk4_paper", None, 0.002), "`rk4_paper` dτ = 2e-3 (the packaged inputs' method)",
     "reproducing the paper's figures (its first-order scheme)"))


def check_readme(ck, group="readme"):
    doc = "README.md"
    pc = load(result_path("period_cost.json"))
    rows = _period_cost_rows(pc)
    t7, t10 = rows[("tilted_hertz_3", "flight_exact", 1e-7)], rows[("tilted_hertz_3", "flight_exact", 1e-10)]
    u7, u10 = (rows[("untilted_3_no_contact_damping", "flight_exact", r)] for r in (1e-7, 1e-10))
    us = lambda r, p="": f"{r[p + 'us_per_period']:.0f}"            # noqa: E731
    k = lambda r, p="": f"{r[p + 'instructions_per_period'] / 1e3:.0f}"  # noqa: E731
    sp = "Performance"
    ck.text(group, doc, "`flight_exact` rtol 1e-7 (V_T error {}), per period (`period_cost.py --repeat 9 "
            "--baseline … --instructions`) | {} µs, {} k instructions | {} µs, {} k |",
            [sci(t7["vt_error"], 2), us(t7), k(t7), us(t7, "baseline_"), k(t7, "baseline_")], sp)
    ck.text(group, doc, "| the same at rtol 1e-10, atol 1e-14 | {} µs, {} k | {} µs, {} k |",
            [us(t10), k(t10), us(t10, "baseline_"), k(t10, "baseline_")], sp)
    ck.text(group, doc, "| the untilted 3-mode scene, rtol 1e-7 (error {}) / rtol 1e-10 | {} / {} µs, {} k / {} k "
            "| {} / {} µs, {} k / {} k |",
            [sci(u7["vt_error"], 2), us(u7), us(u10), k(u7), k(u10), us(u7, "baseline_"), us(u10, "baseline_"),
             k(u7, "baseline_"), k(u10, "baseline_")], sp)
    s = pc["scipy"]
    ck.text(group, doc, "100 periods (`period_cost.py`) | {}× (scipy {} s, tmafm {} ms) | {}×, {}× and {}× "
            "in the three committed runs before |",
            [grouped(s["ratio"]), f"{s['scipy_DOP853_rtol_1e-10']['cpu_s']:.1f}",
             f"{1e3 * s['tmafm_at_equal_error']['cpu_s']:.0f}",
             *[grouped(x) for x in sorted(_earlier_scipy_ratios(3))]], sp)
    rt = load(result_path("run_time.json"))
    case = rt["cases"]["flight_exact_npy"]
    ck.text(group, doc, "| 100-period Fig. 2 run, `flight_exact` at its defaults, {} rows, `.npz` "
            "(`run_time.py --repeat 30 --baseline … --instructions`) | {} ms median, {} ms least, {} M "
            "instructions | main at df69127: {} ms, {} ms, {} M |",
            [grouped(case["rows"]), f"{1e3 * case['median_s']:.1f}", f"{1e3 * case['min_s']:.1f}",
             f"{case['instructions'] / 1e6:.1f}", f"{1e3 * case['baseline_median_s']:.1f}",
             f"{1e3 * case['baseline_min_s']:.1f}", f"{case['baseline_instructions'] / 1e6:.1f}"], sp)
    ck.value(group, doc, "the run_time row's baseline is the JSON's", "main at df69127", rt["baseline"])
    bm = load(result_path("basin_map.json"))["basin"]
    ck.text(group, doc, "| 200 × 200 basin map of Fig. 4 on 2 workers, wall (`basin_map.py`) | {} s "
            "(its committed run; {} µs of CPU per period) |",
            [f"{bm['wall_s']:.1f}", f"{bm['process_cpu_us_per_period']:.0f}"], sp)
    # Methods: dop853 against dopri5 at rtol 1e-10 over the four period_cost scenes
    rhs, cpu = [], []
    for scene in pc["scenes"]:
        a, b = rows[(scene, "dopri5", 1e-10)], rows[(scene, "dop853", 1e-10)]
        rhs.append(a["rhs_per_period_error_window"] / b["rhs_per_period_error_window"])
        cpu.append(a["us_per_period"] / b["us_per_period"])
    ck.text(group, doc, "at rtol 1e-10 it needs {}× fewer in all and runs {}× faster",
            [span(rhs, lambda x: f"{x:.1f}"), span(cpu, lambda x: f"{x:.1f}")], "Methods")
    errors = [rows[(scene, "flight_exact", 1e-7)]["vt_error"] for scene in pc["scenes"]]
    ck.text(group, doc, "over a run the V_T error is larger, {} to {} at the defaults with `flight_exact`",
            [sci(min(errors), 2, "-"), sci(max(errors), 2, "-")], "Input: the namelist groups")
    warp = load(result_path("entry_warp/contact_steps.json"))["rows"]
    fewer = [(r["main"]["steps_per_period"] - r["edges"]["steps_per_period"])
             / (r["main"]["phase_switches_per_period"] / 2)
             for r in warp]
    ck.text(group, doc, "is not: {} steps fewer per contact", [span(fewer, lambda x: f"{x:.0f}")], "Methods")
    # "Which method for what": the Fig. 2 scene's rows at each method's usual tolerance
    fig2 = {(r["method"], r.get("rtol"), r.get("dtau")): r for r in pc["scenes"]["fig2"]["rows"]}
    for (method, rtol, dtau), first, use in METHOD_ROWS:
        r = fig2[(method, rtol, dtau)]
        ck.text(group, doc, f"| {first} | {use} | " + "{} µs | {} |",
                [grouped(r["us_per_period"]), sci(r["vt_error"], 2, "-")], "Methods")
    ow = load(result_path("output_write.json"))["cases"]
    least = min(c["cpu_ratio_text_over_npy"] for c in ow)
    ck.text(group, doc, "archive for `numpy.load`, more than {} times cheaper to write",
            [f"{least // 10 * 10:.0f}" if least >= 10 else f"{least:.1f}"], "Running")
    cs = load(result_path("contact_steps.json"))
    ratio = [r["steps"]["vt_error_over_tolerance"] for r in cs["rows"] if r["method"] == "flight_exact"]
    ck.text(group, doc, "with `flight_exact` a run's V_T error is {}× it",
            [span(ratio, lambda x: f"{x:.1f}")], "Methods")


def _run_of_baseline(instructions):
    """The newest earlier committed run_time.json whose own build is the current baseline (its
    flight_exact_npy instructions within 0.1 % of the baseline's): "the previous committed run"."""
    revs = history("benchmarks/results/run_time.json")
    for rev in revs[1:]:
        case = committed(rev, "benchmarks/results/run_time.json")["cases"]["flight_exact_npy"]
        if abs(case.get("instructions", 0) / instructions - 1) < 1e-3:
            return case
    raise LookupError("no committed run_time.json of the baseline's build")


def _earlier_scipy_ratios(n):
    """The scipy ratios of the n committed period_cost.json before the current one."""
    revs = history("benchmarks/results/period_cost.json")
    return [committed(rev, "benchmarks/results/period_cost.json")["scipy"]["ratio"] for rev in revs[1:n + 1]]


# ----------------------------------------------------------------------------- performance.md
def check_performance(ck, group="performance"):
    doc = "docs/performance.md"
    pc = load(result_path("period_cost.json"))
    rows = _period_cost_rows(pc)
    names = {"tilted_hertz_3": "tilted_hertz_3 (the issue's profile scene)",
             "untilted_3_no_contact_damping": "untilted_3_no_contact_damping", "fig2": "fig2 (N = 4)",
             "dmt_fig7": "dmt_fig7"}
    for scene, label in names.items():
        a, b = rows[(scene, "flight_exact", 1e-7)], rows[(scene, "flight_exact", 1e-10)]
        ck.text(group, doc, f"| {label} | {{}} µs, {'error ' if scene == 'tilted_hertz_3' else ''}{{}} | "
                "{} µs | {} k, {} k | {} µs, {} | {} µs | {} k, {} k |",
                [f"{a['us_per_period']:.0f}", sci(a["vt_error"], 2), f"{a['baseline_us_per_period']:.0f}",
                 f"{a['instructions_per_period'] / 1e3:.0f}", f"{a['baseline_instructions_per_period'] / 1e3:.0f}",
                 f"{b['us_per_period']:.0f}", sci(b["vt_error"], 2), f"{b['baseline_us_per_period']:.0f}",
                 f"{b['instructions_per_period'] / 1e3:.0f}", f"{b['baseline_instructions_per_period'] / 1e3:.0f}"],
                "Where the speed targets stand")
    s = pc["scipy"]
    ck.text(group, doc, "took {} s of CPU in this run; `flight_exact` at equal error (rtol 1e-10, V_T error {} "
            "against scipy's {}) took {} ms for the whole process: {}× (the three committed runs before: {}×, "
            "{}× and {}×)",
            [f"{s['scipy_DOP853_rtol_1e-10']['cpu_s']:.1f}", sci(s["tmafm_at_equal_error"]["vt_error"], 2),
             sci(s["scipy_DOP853_rtol_1e-10"]["vt_error"], 2), f"{1e3 * s['tmafm_at_equal_error']['cpu_s']:.0f}",
             grouped(s["ratio"]), *[grouped(x) for x in sorted(_earlier_scipy_ratios(3))]],
            "Where the speed targets stand")
    rt = load(result_path("run_time.json"))
    c = rt["cases"]["flight_exact_npy"]
    ck.text(group, doc, "`flight_exact` at its defaults and `.npz` output ({} rows) takes {} M instructions "
            "against main's {} M at df69127",
            [grouped(c["rows"]), f"{c['instructions'] / 1e6:.1f}", f"{c['baseline_instructions'] / 1e6:.1f}"],
            "Where the speed targets stand")
    ck.text(group, doc, "and {} ms median, {} ms least, against main's {} ms and {} ms in the same loop "
            "(ratio of medians {})",
            [f"{1e3 * c['median_s']:.1f}", f"{1e3 * c['min_s']:.1f}", f"{1e3 * c['baseline_median_s']:.1f}",
             f"{1e3 * c['baseline_min_s']:.1f}", f"{c['baseline_over_this']:.2f}"], "Where the speed targets stand")

    prev = _run_of_baseline(c["baseline_instructions"])
    ck.text(group, doc, "Main's code (df69127) measured {} ms median and {} ms least in the previous committed run",
            [f"{1e3 * prev['median_s']:.1f}", f"{1e3 * prev['min_s']:.1f}"], "Where the speed targets stand")
    ck.text(group, doc, "(the same binary, {} to {} ms within one run)",
            [f"{1e3 * prev['baseline_min_s']:.1f}", f"{1e3 * prev['baseline_max_s']:.1f}"],
            "Where the speed targets stand")

    # the basin map and the approach/retract curve
    sb = "A 200 × 200 basin map"
    full = load(result_path("basin_map.json"))
    bm, ar = full["basin"], full["approach_retract"]
    load_avg = bm["load_average_1min_before_after"]
    ck.text(group, doc, "(`benchmarks/results/basin_map.json`; load average {} before and {} after, on {} cores;",
            [f"{load_avg[0]:.1f}", f"{load_avg[1]:.1f}", full["cpu_count"]], sb)
    ck.text(group, doc, "| 200 × 200 basin map, 2 workers | **{} s** (target 60 s) | {} s | {} | {} | {} % |",
            [f"{bm['wall_s']:.1f}", f"{bm['process_cpu_s']:.1f}", grouped(bm["periods_run"], ","),
             f"{bm['periods_per_grid_point']:.1f}", f"{100 * bm['outside_core_fraction']:.1f}"], sb)
    ck.text(group, doc, "| 200-point approach/retract (`inputs/sweeps/bistable_n2.nml`) | {} s | {} s | {} |",
            [f"{ar['wall_s']:.1f}", f"{ar['process_cpu_s']:.1f}", grouped(ar["periods_run"], ",")], sb)
    early = committed("12c4308", "benchmarks/results/basin_map.json")["basin"]
    ck.text(group, doc, "An earlier run of the same command at commit 12c4308, before the last inlining change, "
            "at load 0.8–1.3, took {} s of wall time and {} s of CPU",
            [f"{early['wall_s']:.1f}", f"{early['process_cpu_s']:.1f}"], sb)
    old = committed("c951a35", "benchmarks/results/basin_map.json")["basin"]
    ck.text(group, doc, "| the same map at commit e9a82f9 (quiet machine) | {} s | {} s | {} | {} | {} % |",
            [f"{old['wall_s']:.0f}", f"{old['process_cpu_s']:.0f}", grouped(old["periods_run"]),
             f"{old['periods_run'] / (bm['grid'][0] * bm['grid'][1]):.1f}",
             f"{100 * old['outside_core_fraction']:.1f}"], sb)
    ck.text(group, doc, "All {} points reach the one {} attractor; {} of them stopped early at it",
            [grouped(sum(bm["points_per_label"].values())),
             "period-" + common(list(bm["points_per_period"])) if bm["attractors"] == 1 else "several",
             grouped(bm["stopped_at_known_attractor"], ",")], sb)
    ck.text(group, doc, "after a first pass of every {}th point", [bm["coarse_stride"]], sb)
    ck.text(group, doc, "{} µs of CPU per period, everything included. Where the {}× in wall time came from:",
            [f"{bm['process_cpu_us_per_period']:.0f}", f"{old['wall_s'] / bm['wall_s']:.0f}"], sb)
    ck.text(group, doc, "known-attractor stops: {} periods per point instead of {};",
            [f"{bm['periods_per_grid_point']:.1f}", f"{old['periods_run'] / 40000:.1f}"], sb)
    ck.text(group, doc, "the map runs the full {} periods;", [grouped(old["periods_run"])], sb)
    ck.text(group, doc, "vectorised ({} % of the wall time is outside the core, imports excluded: {} s).",
            [f"{100 * bm['outside_core_fraction']:.1f}", f"{bm['imports_s']:.1f}"], sb)
    ck.text(group, doc, "The approach/retract jumps are at δ̂ = {} on approach and {} on retract.",
            [f"{ar['jumps']['approach'][0]:.5f}", f"{ar['jumps']['retract'][0]:.5f}"], sb)

    # the tables a benchmark's own table function prints
    cs = bench_module("contact_steps")
    for path, section in (("contact_steps.json", "Step control at contact exits"),
                          ("entry_warp/contact_steps.json", "Warped steps after a contact entry")):
        report = load(result_path(path))
        for line in cs.table(report).splitlines()[2:]:
            ck.row(group, doc, line, 3, section)
    report = load(result_path("entry_warp/pairs/contact_steps.json"))
    for line in cs.table(report).splitlines()[2:]:
        ck.row(group, doc, line, 3, "Warped steps after a contact entry")

    # the cost against N
    sc = load(result_path("scaling.json"))["methods"]
    for method, entry in sc.items():
        by_n = {r["n_modes"]: r for r in entry["rows"]}
        cells = []
        for n, decimals in ((4, 1), (12, 1), (30, 0)):   # the N = 30 column in whole ms
            ms = 1e3 * by_n[n]["seconds_per_period"]
            cells += [f"{ms:.{decimals}f}", f"{by_n[n]['rhs_per_period']:.0f}"]
        ns = [n for n in by_n if n >= 4]
        slope = _loglog_slope([math.log(n) for n in ns], [math.log(by_n[n]["seconds_per_period"]) for n in ns])
        ck.text(group, doc, f"| `{method}` | {{}} ({{}}) | {{}} ({{}}) | {{}} ({{}}) | {{}} |",
                cells + [f"{slope:.2f}"], "Cost against the number of modes")

    # the right-hand side and whole processes (rhs_cost.json)
    rc = load(result_path("rhs_cost.json"))
    b = rc["builds"]
    for n in ("1", "3", "4", "8", "30"):
        o, w = b["old"]["rhs"][n], b["new"]["rhs"][n]
        ck.text(group, doc, f"| {n} | {{}} → {{}} | {{}} → {{}} | {{}} → {{}} | {{}} → {{}} |",
                [f"{x:.0f}" for k in ("free_ns", "contact_ns", "free_at_phase_ns", "contact_at_phase_ns")
                 for x in (o[k], w[k])], "The right-hand side, the flight scan")
    runs = rc["runs"]
    for scene, label in (("tilted_hertz_3", "tilted_hertz_3, 1000 periods"),
                         ("fig2", "fig2, 100 periods, 31 416 samples")):
        r = runs[scene]
        ck.text(group, doc, f"| {label} | {{}} ms | {{}} ms ({{}}×) | {{}} ms ({{}}×) |",
                [f"{r['old']['median_ms']:.1f}", f"{r['new_no_lto']['median_ms']:.1f}",
                 f"{r['old']['median_ms'] / r['new_no_lto']['median_ms']:.2f}", f"{r['new']['median_ms']:.1f}",
                 f"{r['old']['median_ms'] / r['new']['median_ms']:.2f}"], "The right-hand side, the flight scan")
    r = runs["tilted_hertz_3"]
    ck.text(group, doc, "| tilted_hertz_3, instructions (callgrind) | {} M | {} M ({}×) | {} M ({}×) |",
            [f"{r['old']['instructions'] / 1e6:.0f}", f"{r['new_no_lto']['instructions'] / 1e6:.0f}",
             f"{r['old']['instructions'] / r['new_no_lto']['instructions']:.2f}",
             f"{r['new']['instructions'] / 1e6:.0f}", f"{r['old']['instructions'] / r['new']['instructions']:.2f}"],
            "The right-hand side, the flight scan")
    t, f = runs["tilted_hertz_3"], runs["fig2"]
    ck.text(group, doc, "(tilted: {} steps, {} rejected; Fig. 2: {} and {}); the right-hand-side counts differ "
            "by {} and {} ({} → {}, {} → {})",
            [t["old"]["counters"]["steps"], t["old"]["counters"]["rejected_steps"], f["old"]["counters"]["steps"],
             f["old"]["counters"]["rejected_steps"],
             t["new"]["counters"]["rhs_evaluations"] - t["old"]["counters"]["rhs_evaluations"],
             f["new"]["counters"]["rhs_evaluations"] - f["old"]["counters"]["rhs_evaluations"],
             t["old"]["counters"]["rhs_evaluations"], t["new"]["counters"]["rhs_evaluations"],
             f["old"]["counters"]["rhs_evaluations"], f["new"]["counters"]["rhs_evaluations"]],
            "The right-hand side, the flight scan")

    # the Python layer
    po = load(result_path("python_overhead.json"))
    ms = po["short_call"]["cpu_ms_per_call"]
    sp = "The Python layer's own cost"
    for label, key, fmt in (("`tmafm.run(dict)`", "run_dict", "{:.3f}"),
                            ("`tmafm.run(path, solver={...})` (a file plus an override)", "run_path", "{:.2f}"),
                            ("a reused `Config.run()`", "config_run", "{:.3f}")):
        ck.text(group, doc, f"| {label} | {{}} |", [fmt.format(ms[key])], sp)
    th = po["throughput"]
    rate = th["scenes_per_s"]
    ck.text(group, doc, "| 1 | {} | {} |", [f"{rate['threads_1']:.1f}", f"{rate['processes_1']:.1f}"], sp)
    ck.text(group, doc, "| 2 | {} ({}×) | {} ({}×) |",
            [f"{rate['threads_2']:.1f}", f"{th['speedup_2_threads']:.2f}", f"{rate['processes_2']:.1f}",
             f"{th['speedup_2_processes']:.2f}"], sp)
    ck.text(group, doc, "Two threads used {} CPU-seconds per wall second",
            [f"{th['cpu_seconds_per_wall_second']['threads_2']:.2f}"], sp)
    ck.text(group, doc, "the throughput of threads against processes on {} short scenes (τ_end = {})",
            [th["scenes"], f"{th['tau_end']:.0f}"], sp)
    ck.text(group, doc, "(τ_end = 0.1, N = 4, {} steps)", [po["short_call"]["counters"]["steps"]], sp)
    ck.text(group, doc, "Measured on the 2-core machine with nothing else running (load average {})",
            [f"{po['load_average'][0]:.1f}"], sp)

    # sweep throughput
    st = load(result_path("sweep_throughput.json"))
    by = {(r["backend"], r["workers"]): r for r in st["rows"]}
    labels = {"batch (OpenMP threads)": "core batch (OpenMP threads)", "process pool": "process pool",
              "dask (threads)": "Dask LocalCluster, threads", "dask (processes)": "Dask LocalCluster, processes"}
    for backend, label in labels.items():
        one, two = by[(backend, 1)], by[(backend, 2)]
        ck.text(group, doc, f"| {label} | {{}}, {{}} | {{}}, {{}} ({{}}×) |",
                [f"{one['runs_per_s']:.1f}", grouped(one["periods_per_s"]), f"{two['runs_per_s']:.1f}",
                 grouped(two["periods_per_s"]), f"{two['runs_per_s'] / one['runs_per_s']:.2f}"],
            "Throughput by backend")
    ck.text(group, doc, "The grid is {} runs of the Fig. 2 scene", [st["runs"]], "Throughput by backend")
    ck.text(group, doc, "Each run is exactly {} periods", [st["periods_per_run"]], "Throughput by backend")

    _etd_table(ck, group, doc)
    check_off_cost(ck, group)
    check_forces_off_cost(ck, group)
    check_fuzz_campaign(ck)
    _off_cost_rows(ck, group, "off_cost_capillary.json")
    _off_cost_rows(ck, group, "off_cost_window.json")
    _off_cost_rows(ck, group, "off_cost_thermal.json")
    _off_cost_rows(ck, group, "off_cost_noise_flight.json")
    check_noise_methods(ck, group)
    check_compose_cost(ck, group)
    check_longrange(ck, group)
    check_etd_flight(ck, group)
    check_observer_pieces(ck, group)
    _inventory(ck, group, doc)


def _etd_table(ck, group, doc):
    """The exponential collocation probe's table: etd_probe.py's own interpolation on its JSON."""
    etd = bench_module("etd_probe")
    results = load(result_path("etd_probe.json"))["results"]
    methods = ("dop853", "lawson", "etd_gauss6_stagenewton1", "etd_gauss6_stagenewton1_x3")
    labels = {"fig2": "Fig. 2", "tilted_hertz_3": "tilted"}
    for res in results:
        rows, real = res["rows"], res["real"]
        first = "tmafm's rtol 1e-7" if res["scene"] == "fig2" else "rtol 1e-7"   # as the rows say
        for kind, rtol, fixed in ((first, "1e-07", None), ("rtol 1e-10", "1e-10", None),
                                  (None, None, 1e-10), (None, None, 1e-13)):
            target = real[rtol]["vt_error"] if rtol else fixed
            cells = []
            for method in methods:
                mine = [r for r in rows if r["method"] == method]
                for key, fmt in (("steps", "{:.1f}"), ("work", "{:.0f}"), ("equivalents", "{:.0f}")):
                    value = etd.interpolate_work([(r.get(key), r["vt_error"]) for r in mine], target)
                    cells.append("not reached" if value is None else fmt.format(value))
            head = (f"| {labels[res['scene']]}, {{}} ({kind}) |" if kind else
                    f"| {labels[res['scene']]}, {sci(fixed, 1)} |")
            ck.text(group, doc, head + " {}, {}, {} |" * len(methods), ([sci(target, 2)] if kind else []) + cells,
                    "An exponential collocation probe")


def _loglog_slope(x, y):
    n = len(x)
    mx, my = sum(x) / n, sum(y) / n
    return sum((a - mx) * (b - my) for a, b in zip(x, y)) / sum((a - mx) ** 2 for a in x)


#: performance.md's tables that no committed JSON backs: (first header cell + heading, why).
NO_SOURCE = {
    "The step loop's bookkeeping": "stage_cost.py and contact_steps.py wrote to /tmp/sc and /tmp/cs",
    "A dop853 contact step besides its right-hand sides": "stage_cost.py's output in /tmp",
    "The first steps in tau after the warp": "trial builds, not kept (handover_trials.patch)",
    "Where the kernel's time goes": "perf measurements, no JSON",
    "The rows of a flight written in place": "callgrind runs, no JSON",
    "The earlier steps": "callgrind runs at e9a82f9, no JSON",
}


def _tables(text):
    """(heading, first row line, [body row line numbers]) of each markdown table, code skipped."""
    tables, heading, fenced, current = [], None, False, None
    for number, line in enumerate(text.splitlines(), 1):
        if line.startswith("```"):
            fenced = not fenced
        if fenced:
            continue
        if re.match(r"#+ ", line):
            heading = line.lstrip("#").strip()
        if line.startswith("|---"):
            current = (heading, number - 1, [])
            tables.append(current)
        elif line.startswith("|") and current is not None and current[2] is not None:
            current[2].append(number)
        else:
            current = None
    return tables


def _inventory(ck, group, doc):
    """Every table of performance.md is checked row by row, or named in NO_SOURCE with why."""
    checked = {int(r.where.rsplit(":", 1)[1]) for r in ck.rows
               if r.ok is not None and r.where.startswith(doc + ":")}
    for heading, first, body in _tables(ck.doc(doc)):
        why = next((why for key, why in NO_SOURCE.items() if heading.startswith(key)), None)
        missing = [n for n in body if n not in checked]
        if why is not None and len(missing) == len(body):
            ck.unchecked(group, f"{doc}:{first}", f"table under '{heading}'", why)
        elif missing:
            ck.value(group, f"{doc}:{first}", f"table under '{heading}': every row checked",
                     f"{len(body) - len(missing)} of {len(body)} rows", f"{len(body)} of {len(body)} rows",
                     ok=False)


# ----------------------------------------------------------------------------- other docs
def check_other_docs(ck, group="docs"):
    oo = load(result_path("observe_overhead.json"))
    for method, r in oo["rows"].items():
        ck.text(group, "docs/observables.md", f"| `{method}` | {{}}× | {{}}× | {{}}× | {{}}× | {{}}× | {{}}× |",
                [f"{r['ratio_' + g]:.1f}" for g in ("all", "lockin", "extrema", "peak_force", "energy", "none")],
                "Cost")
    ck.text(group, "docs/observables.md", "times fig3 over {} periods", [oo["periods"]], "Cost")
    ow = load(result_path("output_write.json"))
    a, b = ow["cases"]
    ck.text(group, "docs/output-format.md",
            "| Fig. 2, N = 4, τ = 100π (`rk4_paper`) | {} | {} µs/row ({} ms, {} MB) | {} µs/row ({} ms, {} MB) | {} |",
            [grouped(a["rows"]), f"{a['text']['cpu_us_per_row']:.2f}", f"{1e3 * a['text']['cpu_s']:.0f}",
             f"{a['bytes']['text'] / 1e6:.1f}", f"{a['npy']['cpu_us_per_row']:.2f}", f"{1e3 * a['npy']['cpu_s']:.1f}",
             f"{a['bytes']['npy'] / 1e6:.1f}", f"{a['cpu_ratio_text_over_npy']:.1f}"], "Cost")
    ck.text(group, "docs/output-format.md",
            "| Fig. 2, N = 16, τ = 50π (`dopri5`) | {} | {} µs/row | {} µs/row | {} |",
            [grouped(b["rows"]), f"{b['text']['cpu_us_per_row']:.2f}", f"{b['npy']['cpu_us_per_row']:.2f}",
             f"{b['cpu_ratio_text_over_npy']:.1f}"], "Cost")
    ck.text(group, "docs/output-format.md", "{} s (text) and {} s (`.npz`) for the first run",
            [f"{a['text']['wall_s']:.2f}", f"{a['npy']['wall_s']:.3f}"], "Cost")
    api = load(result_path("api_campaign.json"))
    ck.text(group, "docs/reliability.md", "commit {}): of {} calls over {} entry\npoints, {} broke the "
            "contract: {} returned and {} were refused with a typed error, in\n{} s CPU",
            [api["commit"][:7], grouped(api["calls"]), len(api["by_entry"]), api["broke_contract"],
             grouped(api["outcomes"].get("ok", 0)), grouped(api["outcomes"].get("ok-error", 0)),
             api["cpu_s"]], None)
    sd = {(r["method"], json.dumps(r["solver"], sort_keys=True), json.dumps(r["model"], sort_keys=True)): r
          for r in load(result_path("steady_dop853.json")) if "input" not in r}
    n4 = json.dumps({"n_modes": 4})
    defaults = json.dumps({"atol": 1e-10, "rtol": 1e-7}, sort_keys=True)
    capped = sd[("dopri5", defaults, n4)]
    ck.value(group, "docs/observables.md", "dopri5, N = 4 at the defaults: a period", "1",
             str(capped["period"]))
    ck.text(group, "docs/observables.md", "where `dop853` and `flight_exact` find period 1 after {}",
            [sd[("dop853", defaults, n4)]["periods_run"]], None)
    ck.value(group, "docs/observables.md", "flight_exact, N = 4: the same periods",
             str(sd[("dop853", defaults, n4)]["periods_run"]), str(sd[("flight_exact", defaults, n4)]["periods_run"]))
    ck.text(group, "docs/observables.md", "Capped inside the\n  interval it finds it after {} too",
            [capped["periods_run"]], None)
    ck.text(group, "docs/observables.md", "(mean h ω_4 from 1.13 to\n  {}; ", [f"{capped['mean_h_omega_n']:.2f}"], None)
    bl = load(result_path("basin_labels.json"))
    bud = bl["budget"]
    doc = "docs/sweeps.md"
    waits = bud["periods_the_test_waits_after_that"]
    ck.text(group, doc, "follows {} random Fig. 4 runs", [bud["points"]], None)
    ck.text(group, doc, "| period where the steady-state test stops a run (mean) | {} |",
            [f"{bud['test_stops_at_period_mean']:.1f}"], None)
    ck.text(group, doc, "| first period within `steady_tol` of the run's own attractor (mean) | {} |",
            [f"{bud['first_period_within_steady_tol_mean']:.1f}"], None)
    ck.text(group, doc,
            "| periods the test waits after that (3 / 4 / 5 / 6 periods) | {} / {} / {} / {} runs, mean {} |",
            [waits[k] for k in ("3", "4", "5", "6")] + [f"{bud['periods_the_test_waits_mean']:.1f}"], None)
    ck.text(group, doc, "| contraction of the distance per period (median) | {} |",
            [f"{bud['median_contraction_per_period']:.2f}"], None)
    spread = bud["attractor_point_spread_over_runs_in_steady_tol"]
    ck.text(group, doc, "| spread of the 60 runs' attractor points, in units of `steady_tol` | median {}, max {} |",
            [f"{spread['median']:.1f}", f"{spread['max']:.1f}"], None)
    for key, label in (("fig4_every_10th_of_200x200", "Fig. 4, 20 × 20"),
                       ("bistable_n2_delta_3e-3", "bistable, 13 × 13")):
        m = bl["maps"][key]
        labels = ", ".join(f"{k} ({v})" for k, v in m["rtol_1e-08_full"]["points_per_label"].items())
        ck.value(group, doc, f"{label}: the four label maps are identical",
                 "identical", "identical" if all(m["labels_equal_to_rtol_1e-08_full"].values()) else "differ")
        ck.text(group, doc, f"| {label} | {labels} | {{}} / {{}} | {{}} / {{}} |",
                [grouped(m[f"rtol_{r}_{s}"]["periods_run"]) for r in ("1e-08", "1e-10") for s in ("full", "known")],
                None)


def check_errata(ck, group="errata"):
    """docs/errata.md's measured effects, from benchmarks/errata_effects.json."""
    doc = "docs/errata.md"
    fx = load(result_path("errata_effects.json"))["effects"]

    def dv(e):
        return sci(fx[e]["max_abs_vt_change_last_period"], 3 if fx[e]["max_abs_vt_change_last_period"] > 1e-5 else 2)

    def rel(e, decimals):
        return f"{100 * fx[e]['relative_change']:.{decimals}f}"

    none = fx["none"]
    ck.text(group, doc, "The printed run has contact fraction {}, V_T ∈ [{}, {}], and {} dissipated per period.",
            [f"{none['contact_fraction']:.3f}", sci(none["vt_min"], 4), sci(none["vt_max"], 4),
             sci(none["dissipated_per_period"], 4)], None)
    ck.text(group, doc, "ΔV_T = {} ({} %). The contact fraction rises to {}, the dissipation falls to {}, and the "
            "motion stays {}.", [dv("E1"), rel("E1", 1), f"{fx['E1']['contact_fraction']:.3f}",
                                 sci(fx["E1"]["dissipated_per_period"], 4), fx["E1"]["classification"]], "E1:")
    ck.text(group, doc, "(ΔV_T = {}). It matters only", [sci(fx["E2"]["max_abs_vt_change_last_period"], 1)
                                                        if fx["E2"]["max_abs_vt_change_last_period"] else "0"], "E2:")
    ck.text(group, doc, "ΔV_T = {} ({} %). The dissipation is {}.",
            [sci(fx["E3"]["max_abs_vt_change_last_period"], 2), rel("E3", 2),
             sci(fx["E3"]["dissipated_per_period"], 4)],
            "E3:")
    ck.text(group, doc, "ΔV_T = {} ({} %). Contact gets deeper (V_T_min = {}) and longer (contact fraction {}).",
            [dv("E4"), rel("E4", 1), sci(fx["E4"]["vt_min"], 4), f"{fx['E4']['contact_fraction']:.3f}"], "E4:")
    ck.text(group, doc, "none at ξ0 = 1 (ΔV_T = {}).", [sci(fx["E6"]["max_abs_vt_change_last_period"], 1)
                                                        if fx["E6"]["max_abs_vt_change_last_period"] else "0"], "E6:")
    ck.text(group, doc, "ΔV_T = {} ({} relative).",
            [sci(fx["E7"]["max_abs_vt_change_last_period"], 2, "-"), sci(fx["E7"]["relative_change"], 1, "-")], "E7:")
    a = fx["all"]
    ck.text(group, doc, "`consistent` gives ΔV_T = {} ({} %), contact fraction {}, V_T ∈ [{}, {}], and {} dissipated "
            "per period.", [dv("all"), rel("all", 0), f"{a['contact_fraction']:.3f}", sci(a["vt_min"], 4),
                            sci(a["vt_max"], 4), sci(a["dissipated_per_period"], 4)], "All together")


# ----------------------------------------------------------------------------- recomputed
REL = 1e-6   # reals recomputed on this build against the committed JSON (runs: 1e-9; docs: 4 digits)
#: rk4_paper cases whose classification reproduction.md quotes.  The stable ones keep their
#: verdict when a1(0) moves by +-1e-16 or +-1e-15 (measured); the verdicts of the others flip
#: with it (fig2_n2 consistent: period-2 or period-1; fig7_hertz: period-8 or period-6), so they
#: are round-off: the docs name both, and only --recompute checks them, on this machine.
RK4_STABLE = ["fig2_n4/rk4_paper/paper", "fig6/rk4_paper/consistent", "fig7_dmt/rk4_paper/paper",
              "fig7_hertz/rk4_paper/paper"]
RK4_FRAGILE = {"fig2_n2/rk4_paper/consistent":
               ("Fig. 2:", 'N = 2 comes out as "{}" (or "{}" with a1(0) moved by 1e-16')}
NUDGE = 1e-16
DETERMINISTIC = ("classification", "period", "contacts_per_period")
REALS = ("vt_min", "vt_max", "contact_fraction", "dissipated_per_period")


RERUN = ("committed", "rerun")


def compare_case(ck, group, key, old, new, labels_only=False):
    """A summary case recomputed against the committed one (rk4_paper: its labels only, its
    reals follow its round-off jitter)."""
    for field in DETERMINISTIC:
        ck.value(group, f"summary.json {key}", field, old[field], new[field], labels=RERUN)
    if labels_only:
        return
    for field in ("reached", "period"):
        ck.value(group, f"summary.json {key}", f"steady_state.{field}",
                 old["steady_state"][field], new["steady_state"][field], labels=RERUN)
    for field in REALS:
        a, b = old[field], new[field]
        ck.value(group, f"summary.json {key}", f"{field} (to {REL:g} relative)", f"{a:.9g}", f"{b:.9g}",
                 ok=abs(a - b) <= REL * max(abs(a), abs(b)), labels=RERUN)


def recompute(ck, group="recompute", fragile=True):
    """The deterministic numbers behind the docs, computed again on this build; `fragile`: also
    the round-off verdicts of RK4_FRAGILE (on this machine only)."""
    import tmafm
    from tmafm import analysis, figures

    summary = load(SUMMARY)
    keys = [k for k in summary["cases"] if k.split("/")[1] == "flight_exact"] + RK4_STABLE
    for key in keys:
        name, method, convention = key.split("/")
        result = figures.simulate(None, name, method, convention, summary["periods"])
        compare_case(ck, group, key, summary["cases"][key], analysis.summary(result),
                     labels_only=method == "rk4_paper")
    for key, (section, template) in RK4_FRAGILE.items() if fragile else ():
        name, method, convention = key.split("/")
        n = tmafm.Config(tmafm.inputs.path(name)).to_dict()["model"]["n_modes"]
        labels = []
        for nudge in (0.0, NUDGE, -NUDGE):
            extra = {"initial": {"a0": [nudge] + [0.0] * (n - 1)}} if nudge else {}
            result = figures.simulate(None, name, method, convention, summary["periods"], **extra)
            labels.append(analysis.classify_period(result, max_period=8, window=8)["kind"])
        ck.value(group, f"summary.json {key}", "classification", summary["cases"][key]["classification"],
                 labels[0], labels=RERUN)
        others = sorted(set(labels[1:]) - {labels[0]})
        ck.text(group, "docs/reproduction.md", template, [labels[0], ", ".join(others) or "none"], section)
    # Fig. 6: "exactly one switch in τ ≤ 10: the landing"
    r = tmafm.run("fig6", solver={"method": "flight_exact", "rtol": 1e-9, "atol": 1e-15, "tau_end": 10})
    landing = "one" if len(r.switches) == 1 and r.contact[-1] == 1 else f"{len(r.switches)} switches"
    ck.text(group, "docs/reproduction.md", "have exactly {} switch in τ ≤ 10: the landing.", [landing], "Fig. 6:")
    # Fig. 7 over 300 periods, as benchmarks/period_search.py runs it
    ps = bench_module("period_search")
    search = load(result_path("period_search.json"))
    for key, old in search["fig7"].items():
        name, periods = key.split("/")
        new = ps.classify(name, int(periods))
        ck.value(group, f"period_search.json {key}", "classification", old["classification"],
                 new["classification"], labels=RERUN)
        ck.value(group, f"period_search.json {key}", "steady_tau", old["steady_tau"] and f"{old['steady_tau']:.6g}",
                 new["steady_tau"] and f"{new['steady_tau']:.6g}", labels=RERUN)
    # the V_T errors the docs quote from period_cost.json (flight_exact at the headline tolerances)
    pc = bench_module("period_cost")
    rows = _period_cost_rows(load(result_path("period_cost.json")))
    for scene in pc.SCENES:
        reference = tmafm.run(pc.groups(scene, {"method": "flight_exact", "rtol": 1e-13, "atol": 1e-18},
                                        pc.ERROR_PERIODS, 0.05, "unused.dat")).vt
        for rtol, atol in pc.HEADLINE:
            error, _ = pc.vt_error(scene, {"method": "flight_exact", "rtol": rtol, "atol": atol}, reference)
            ck.value(group, f"period_cost.json {scene}", f"flight_exact rtol {rtol:g}: V_T error (2 digits)",
                     sci(rows[(scene, "flight_exact", rtol)]["vt_error"], 2, "-"), sci(error, 2, "-"), labels=RERUN)
    # the 100-period Fig. 2 run of run_time.json: its rows and counters
    rt = load(result_path("run_time.json"))
    for name, case in rt["cases"].items():
        if case["method"] != "flight_exact":
            continue
        result = tmafm.Config("fig2_n4", solver={"method": case["method"], "tau_end": rt["tau_end"]}).run()
        ck.value(group, f"run_time.json {name}", "rows", case["rows"], len(result.tau), labels=RERUN)
        ck.value(group, f"run_time.json {name}", "counters", json.dumps(case["counters"], sort_keys=True),
                 json.dumps(result.counters, sort_keys=True), labels=RERUN)


def rerun_figures(ck, group="figures-rerun"):
    """Rerun the documented command into a temporary folder; compare and return its summary."""
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, "-m", "tmafm.figures", "--out", tmp, "--periods", "100", "--basin", "41"],
                       check=True, stdout=subprocess.DEVNULL)
        new = load(Path(tmp) / "summary.json")
    old = load(SUMMARY)
    ck.value(group, "summary.json", "cases", sorted(old["cases"]), sorted(new["cases"]), labels=RERUN)
    for key in old["cases"]:
        if key in new["cases"]:
            compare_case(ck, group, key, old["cases"][key], new["cases"][key], labels_only="/rk4_paper/" in key)
    for convention, rows in old["basin"]["rows"].items():
        ck.value(group, "summary.json basin", f"{convention}: classifications",
                 [r["classification"] for r in rows], [r["classification"] for r in new["basin"]["rows"][convention]],
                 labels=RERUN)
    return new


# ----------------------------------------------------------------------------- timings rerun
def _run_time_values(report):
    case = report["cases"]["flight_exact_npy"]
    return ({"flight_exact_npy median_s": case["median_s"], "flight_exact_npy min_s": case["min_s"]},
            {"flight_exact_npy rows": case["rows"], "flight_exact_npy counters": case["counters"]})


def _basin_map_values(report):
    b, a = report["basin"], report["approach_retract"]
    return ({"basin wall_s": b["wall_s"], "basin process_cpu_s": b["process_cpu_s"],
             "basin process_cpu_us_per_period": b["process_cpu_us_per_period"],
             "approach_retract process_cpu_s": a["process_cpu_s"]},
            {"basin points_per_label": b["points_per_label"], "basin failures": b["failures"],
             "basin points_per_period": b["points_per_period"], "approach_retract jumps": a["jumps"],
             "approach_retract periods_run": a["periods_run"]})


def _period_cost_values(report):
    rows = _period_cost_rows(report)
    timed, exact = {"scipy ratio": report["scipy"]["ratio"]}, {}
    for scene in ("tilted_hertz_3", "untilted_3_no_contact_damping"):
        for rtol in (1e-7, 1e-10):
            r = rows[(scene, "flight_exact", rtol)]
            timed[f"{scene} flight_exact rtol {rtol:g} us_per_period"] = r["us_per_period"]
            exact[f"{scene} flight_exact rtol {rtol:g} vt_error"] = sci(r["vt_error"], 2, "-")
    return timed, exact


#: The timed benchmarks README cites: command (into {tmp}), the JSON it writes, its values.
TIMINGS = {
    "run_time.json": (["run_time.py", "--repeat", "15", "--out", "{tmp}/run_time.json"], _run_time_values),
    "basin_map.json": (["basin_map.py", "--json", "{tmp}/basin_map.json"], _basin_map_values),
    "period_cost.json": (["period_cost.py", "--out", "{tmp}", "--methods", "flight_exact"], _period_cost_values),
}


def rerun_timings(ck, factor, group="timings-rerun"):
    """Rerun the timed benchmarks; timings within `factor` of the committed ones, the rest equal."""
    with tempfile.TemporaryDirectory() as tmp:
        for name, (command, values) in TIMINGS.items():
            subprocess.run([sys.executable, str(BENCH / command[0]), *[c.format(tmp=tmp) for c in command[1:]]],
                           check=True, stdout=subprocess.DEVNULL, cwd=REPO)
            old_timed, old_exact = values(load(result_path(name)))
            new_timed, new_exact = values(load(Path(tmp) / name))
            for key, a in old_timed.items():
                b = new_timed[key]
                ck.value(group, name, f"{key} (within {factor}x)", f"{a:.4g}", f"{b:.4g}",
                         ok=1 / factor <= b / a <= factor, labels=RERUN)
            for key, a in old_exact.items():
                ck.value(group, name, key, json.dumps(a, sort_keys=True), json.dumps(new_exact[key], sort_keys=True),
                         labels=RERUN)


def am_afm_row(row) -> list:
    """The numbers of one row of docs/sweeps.md's AM-AFM table, formatted as printed."""
    fmt = lambda x, n: f"{x:.{n}f}".replace("-", MINUS)  # noqa: E731
    return [f"{row['z_nm']:.0f}", fmt(row["amplitude_nm"], 2), fmt(row["setpoint"], 3),
            fmt(row["phase_deg"], 1), fmt(row["peak_force_nN"], 2), fmt(row["indentation_nm"], 2),
            fmt(row["tip_sample_power_pW"], 2)]


def check_am_afm(ck, group="am_afm"):
    """docs/sweeps.md's AM-AFM approach curve and README's quick start against
    benchmarks/results/am_afm_approach.json (`python benchmarks/am_afm_approach.py`)."""
    am = load(result_path("am_afm_approach.json"))
    doc, sec = "docs/sweeps.md", "An AM-AFM approach curve"
    ck.text(group, doc, "on one worker, in {} s of CPU (user + sys; {} periods, {} µs per period)",
            [f"{am['cpu_s']:.1f}", grouped(am["periods_run"]), f"{am['cpu_us_per_period']:.0f}"], sec)
    for row in am["approach"]:
        ck.text(group, doc, "| {} | {} | {} | {} | {} | {} | {} |", am_afm_row(row), sec)
    ck.value(group, doc, "approach and retract agree (no jumps)", "[] []",
             " ".join(str(j["at"]) for j in am["jumps"]))
    far = am["approach"][0]
    ck.text(group, doc, "far from the sample the amplitude comes out {} below A0 here",
            [sci((am["free_amplitude_nm"] - far["amplitude_nm"]) / am["free_amplitude_nm"], 2, "-")], sec)
    ck.text(group, doc, "The first contact is at Z = {} nm", [f"{am['contact_onset_nm']['approach']:.0f}"], sec)
    ck.text(group, "README.md", "in {} s of CPU (`python benchmarks/am_afm_approach.py`)",
            [f"{am['cpu_s']:.1f}"], "Quick start")


def check_off_cost(ck, group="off_cost"):
    """docs/performance.md's cost of the optional physics when off against
    benchmarks/results/off_cost.json (`python benchmarks/off_cost.py --base 615b428`)."""
    _off_cost_rows(ck, group, "off_cost.json")


def check_fuzz_campaign(ck, group="reliability"):
    """docs/reliability.md's last fuzz campaign against studies/results/fuzz_campaign.json
    (`python studies/fuzz_campaign.py --cases 10000 --first-seed 30000`)."""
    run = load(REPO / "studies" / "results" / "fuzz_campaign.json")
    first, last = run["seeds"]
    ck.text(group, "docs/reliability.md", "Last run: seeds {}–{} on commit {}",
            [grouped(first), grouped(last), run["commit"][:7]], "Fuzz campaign")
    ck.text(group, "docs/reliability.md", "Of the {} cases, {} broke the contract: {} succeeded",
            [grouped(run["cases"]), run["broke_contract"], grouped(run["outcomes"].get("ok", 0))], "Fuzz campaign")
    ck.text(group, "docs/reliability.md", "text and {} failed as documented. It ran on 2 processes in {} s CPU "
            "and {} s wall", [grouped(run["outcomes"].get("ok-error", 0)), run["cpu_s"], run["wall_s"]],
            "Fuzz campaign")


def check_forces_off_cost(ck, group="off_cost"):
    """docs/performance.md's cost of the forces at a distance and JKR when off against
    benchmarks/results/off_cost_forces.json (`python benchmarks/off_cost.py --base fd2cc5e`); the
    capillary meniscus and the JKR and meniscus continuation against off_cost_capillary.json
    (`--base e8f5b66 --head 41bc323`) is read by check_performance."""
    _off_cost_rows(ck, group, "off_cost_forces.json")


def _off_cost_rows(ck, group, name):
    """The three rows of an off_cost.py JSON in docs/performance.md's table (signed change)."""
    off = load(result_path(name))
    doc, sec = "docs/performance.md", "Optional physics when it is off"
    for run_name, label in (("fig2", "Fig. 2 by `flight_exact`, 100 periods"),
                            ("tilted_hertz_3", "3-mode tilted scene, rtol 1e-10, 200 periods"),
                            ("fig2_n4_rk4_paper", "`inputs/fig2_n4.nml` as packaged (`rk4_paper`)")):
        run = off["runs"][run_name]
        sign = "+" if run["change_percent"] >= 0 else "−"
        ck.text(group, doc, f"| {label} | {{}} | {{}} | {sign}{{}} % |",
                [f"{run['base']:,}", f"{run['head']:,}", f"{abs(run['change_percent']):.3f}"], sec)


def check_noise_methods(ck, group="performance"):
    """docs/performance.md's methods with thermal noise against
    benchmarks/results/noise_methods.json (`python benchmarks/noise_methods.py`)."""
    nm = load(result_path("noise_methods.json"))
    doc, sec = "docs/performance.md", "The methods with thermal noise"
    scenes = nm["scenes"]
    ck.text(group, doc, "which `flight_exact` at rtol 1e-13 meets to\n{} (free) and {} (tapping)",
            [sci_plain(scenes["free"]["flight_exact_1e-13_against_reference"]),
             sci_plain(scenes["tapping"]["flight_exact_1e-13_against_reference"])], sec)
    for name in ("free", "tapping"):
        for row in scenes[name]["rows"]:
            ck.text(group, doc, f"| {name} | `{row['method']}` | {row['rtol']:.0e} | {{}} | {{}} | {{}} |",
                    [sci_plain(row["error"]), f"{1e3 * row['cpu_run_s']:.0f}", f"{1e3 * row['cpu_observe_s']:.0f}"],
                    sec)
    free, tap = scenes["free"]["ratios"], scenes["tapping"]["ratios"]
    run, observe = "dop853_over_flight_exact_run_1e-08", "dop853_over_flight_exact_observe_1e-08"
    ck.text(group, doc, "`dop853` costs {}× `flight_exact`'s CPU on the run and\n  {}× on the observe at rtol 1e-8 "
            "(runs", [f"{free[run]:.2f}", f"{free[observe]:.2f}"], sec)
    ck.text(group, doc, "`dop853` costs {}× `flight_exact`'s CPU on the run and {}× on the observe at\n  rtol 1e-8.",
            [f"{tap[run]:.2f}", f"{tap[observe]:.2f}"], sec)
    ck.text(group, doc, "`dopri5` is the cheapest run here ({}× `flight_exact` at rtol 1e-6)",
            [f"{tap['dopri5_over_flight_exact_run_1e-06']:.2f}"], sec)


def sci_plain(x):
    """x as Python's :.1e writes it (5.0e-10), the docs' table form for errors."""
    return f"{x:.1e}"


def check_compose_cost(ck, group="performance"):
    """docs/performance.md's cost of the composed model (issue 26) against
    benchmarks/results/off_cost_compose.json (`python benchmarks/off_cost.py --base 0a22420
    --json benchmarks/results/off_cost_compose.json`) and benchmarks/results/composed_cost.json
    (`python benchmarks/composed_cost.py`)."""
    doc, sec = "docs/performance.md", "The composed model"
    off = load(result_path("off_cost_compose.json"))
    for name, label in (("fig2", "Fig. 2 by `flight_exact`, 100 periods"),
                        ("tilted_hertz_3", "3-mode tilted scene, rtol 1e-10, 200 periods"),
                        ("fig2_n4_rk4_paper", "`inputs/fig2_n4.nml` as packaged (`rk4_paper`)")):
        run = off["runs"][name]
        sign = "+" if run["change_percent"] >= 0 else "-"
        ck.text(group, doc, f"| {label} | {{}} | {{}} | {sign}{{}} % |",
                [f"{run['base']:,}", f"{run['head']:,}", f"{abs(run['change_percent']):.3f}"], sec)
    composed = load(result_path("composed_cost.json"))
    for name, run in composed["runs"].items():
        ck.text(group, doc, f"| `{name}` | {{}} | {{}} | {{}} |",
                [f"{run['specialised']:,}", f"{run['composed']:,}", f"{run['ratio']:.3f}"], sec)


def check_longrange(ck, group="performance"):
    """docs/performance.md's long-range flight section against benchmarks/results/longrange_flight.json
    (`python benchmarks/longrange_flight.py`): its two tables (the script's table_rows) and the
    ratios and counts the text derives from them."""
    doc, sec = "docs/performance.md", "Long-range forces in flight"
    report = load(result_path("longrange_flight.json"))
    for line in bench_module("longrange_flight").table_rows(report):
        ck.row(group, doc, line, 2 if line.startswith("| vdW") or line.startswith("| DMT") else 1, sec)
    runs, at = report["runs"], report["at_error"]
    lawson, dop853, dmt = runs["vdw_flight_exact"], runs["vdw_dop853"], runs["dmt_flight_exact"]

    def flight(r):
        return r["counters"]["steps"] - r["counters"]["contact_steps"]

    to_dmt = [e["ratio_to_dmt_flight_exact"] for e in at.values()]
    to_dop = [e["ratio_to_dop853"] for e in at.values() if "ratio_to_dop853" in e]
    ck.text(group, doc, "the curve costs {}× its DMT twin", [span(to_dmt, lambda x: f"{x:.2f}")], sec)
    low, high = f"{min(to_dop):.2f}", f"{max(to_dop):.2f}"
    ck.text(group, doc, "(target 1.5×) and {}×", [low if low == high else f"{low}\u2013{high}"], sec)
    ck.text(group, doc, "where it costs {} s: below {}×)",
            [f"{dop853[-1]['cpu_s']:.3f}",
             f"{math.ceil(100 * at['1e-08']['cpu_s']['vdw_flight_exact'] / dop853[-1]['cpu_s']) / 100:.2f}"], sec)
    ck.text(group, doc, "is {}× that of the DMT curve",
            [span([a["error"] / b["error"] for a, b in zip(lawson, dmt)], lambda x: f"{x:.2f}")], sec)
    ratios = [b["error"] / a["error"] for a, b in zip(lawson, dop853)]
    ck.text(group, doc, "where `dop853`'s is {}–{}×", [f"{min(ratios):.1f}", f"{max(ratios):.0f}"], sec)
    ck.text(group, doc, "The contacts cost the same: {}× the DMT curve's contact steps",
            [span([a["counters"]["contact_steps"] / b["counters"]["contact_steps"] for a, b in zip(lawson, dmt)],
                  lambda x: f"{x:.3f}")], sec)
    ck.text(group, doc, "and back ({} runs), {} drive periods a point",
            [report["runs_per_curve"], report["periods_per_point"]], sec)
    flights = flight(dmt[0])
    ck.value(group, doc, "one closed-form step per flight at every rtol", {flight(r) for r in dmt}, {flights})
    ck.text(group, doc, "one closed-form step per flight ({} flights)", [f"{flights:,}"], sec)
    ck.text(group, doc, "the vdW flight takes {} Lawson steps per flight, {}× fewer",
            [span([flight(r) / flights for r in lawson], lambda x: f"{x:.1f}"),
             span([flight(b) / flight(a) for a, b in zip(lawson, dop853)], lambda x: f"{x:.2f}")], sec)
    ck.text(group, doc, "(the vdW curve under `dop853` at rtol 1e-13 is within\n{} of it)",
            [sci(report["reference_check"]["dop853_vs_flight_exact_vdw"], 2)], sec)


def check_etd_flight(ck, group="performance"):
    """docs/performance.md's exponential collocation flight probe against
    studies/results/etd_flight_probe.json (`python studies/etd_flight_probe.py`): its table (the
    study's summary_rows) and the counts the text quotes."""
    doc, sec = "docs/performance.md", "An exponential collocation flight"
    probe = bench_module("etd_flight_probe")
    report = load(result_path("etd_flight_probe.json"))
    for line in probe.summary_rows(report):
        ck.row(group, doc, line, 2, sec)
    shaped = "etd_gauss6_reach0.8_3.0_shaped"
    ratios = {"free": [], "plain": [], "shaped": []}
    for regime in report["regimes"].values():
        for _, costs in probe.equal_error(regime):
            etd = [v for k, v in costs.items() if k != "lawson" and v is not None]
            plain = [v for k, v in costs.items() if k not in ("lawson", shaped) and v is not None]
            if regime["kind"] == "free":
                ratios["free"].append(costs["lawson"] / min(etd))
            else:
                ratios["plain"].append(costs["lawson"] / min(plain))
                ratios["shaped"].append(costs["lawson"] / costs[shaped])
    ck.text(group, doc, "does what was expected of it: {}× fewer right-hand sides",
            [span(ratios["free"], lambda x: f"{x:.2f}")], sec)
    ck.text(group, doc, "In a tapping flight the plain ETD flights gain {}×:",
            [span(ratios["plain"], lambda x: f"{x:.2f}")], sec)
    steps = [r["steps"] for r in report["regimes"]["tapping_12nm"]["runs"][shaped] if r["rtol"] >= 1e-8]
    ck.text(group, doc, "The shaped flight takes {} steps a flight at rtol\n1e-5 … 1e-8 and {}× fewer right-hand sides",
            [span(steps, lambda x: f"{x:.1f}"), span(ratios["shaped"], lambda x: f"{x:.2f}")], sec)
    regimes = report["regimes"]

    def run(regime, method, rtol):
        return next(r for r in regimes[regime]["runs"][method] if r["rtol"] == rtol)

    ck.text(group, doc, "a few steps a period ({} at Z = 25 nm and rtol 1e-7, Gauss 6) where the\n"
            "Lawson flight takes {}",
            [f"{run('free_25nm', 'etd_gauss6_reach1.0', 1e-7)['steps']:.1f}",
             f"{run('free_25nm', 'lawson', 1e-7)['steps']:.1f}"], sec)
    loose = run("tapping_12nm", "etd_gauss6_reach1.0", 1e-5)
    ck.text(group, doc, "the ETD flight (Gauss 6, reach 1) takes {}\nsteps a flight, {} of them at gaps below 5 nm, "
            "and the Lawson flight {}",
            [f"{loose['steps']:.1f}", f"{loose['near_steps']:.2f}",
             f"{run('tapping_12nm', 'lawson', 1e-5)['steps']:.1f}"], sec)
    share = report["curve_share"]
    ck.text(group, doc, "at rtol {} the Lawson flight takes {} of its {}\nflight steps at the {} points with contacts, "
            "{} at the {} without",
            [sci(share["rtol"], 1), f"{share['tapping_flight_steps']:,}",
             f"{share['tapping_flight_steps'] + share['free_flight_steps']:,}", 40 - share["free_points"],
             f"{share['free_flight_steps']:,}", share["free_points"]], sec)
    ck.text(group, doc, "8 tapping flights at Z = {} nm", [f"{regimes['tapping_12nm']['z_nm']:.0f}"], sec)
    to_dmt = [e["ratio_to_dmt_flight_exact"] for e in load(result_path("longrange_flight.json"))["at_error"].values()]
    ck.text(group, doc, "the vdW curve to fall from {}× its DMT twin", [span(to_dmt, lambda x: f"{x:.2f}")], sec)


def check_observer_pieces(ck, group="performance"):
    """docs/performance.md's observer on the noise grid's flight pieces against
    benchmarks/results/observer_pieces.json (`python benchmarks/observer_pieces.py --base 4e74856
    --head 009680e --instructions`): the table's instructions, changes and CPU ratios, and the
    ratios of flight_exact's noisy observe to dop853's."""
    doc, sec = "docs/performance.md", "Observed flights on the noise grid"
    report = load(result_path("observer_pieces.json"))
    cases = report["cases"]
    for name, label in (("noisy_flight_exact", "noisy, `flight_exact`, 400 periods"),
                        ("noisy_dop853", "noisy, `dop853`, 400 periods"),
                        ("quiet_polystyrene", "no noise, `flight_exact`, 4000 periods"),
                        ("quiet_fig2_n3", "`fig2_n3`, `flight_exact`, 1000 periods")):
        row = cases[name]
        change = 100 * (row["instructions_head_over_base"] - 1)
        sign = "+" if change >= 0 else "\u2212"
        ck.text(group, doc, f"| {label} | {{}} | {{}} | {sign}{{}} % | {{}} |",
                [f"{row['base']['instructions']:,}", f"{row['head']['instructions']:,}", f"{abs(change):.2f}",
                 f"{row['cpu_head_over_base']:.2f}"], sec)
    cpu = report["flight_exact_over_dop853_noisy"]

    def ins(build):
        return cases["noisy_flight_exact"][build]["instructions"] / cases["noisy_dop853"][build]["instructions"]

    ck.text(group, doc, "took {}× `dop853`'s CPU time on main and takes {}× now ({}× and {}× its instructions)",
            [f"{cpu['base']:.2f}", f"{cpu['head']:.2f}", f"{ins('base'):.2f}", f"{ins('head'):.2f}"], sec)
    ck.text(group, doc, "the least of {} interleaved runs", [report["repeats"]], sec)


def check_continuation(ck, group="continuation"):
    """docs/performance.md's whole-diagram cost against
    benchmarks/results/continuation_diagram_cost.json (`python
    benchmarks/continuation_diagram_cost.py`), and docs/continuation.md's fold curves against
    studies/results/fold_curves.json (`python studies/fold_curves.py`)."""
    d = load(result_path("continuation_diagram_cost.json"))
    doc, sec = "docs/performance.md", "The whole diagram at the continuation's accuracy"
    ck.text(group, doc, "with its fold, {} points, **{} s**.",
            [str(d["continuation_points"]), f"{d['continuation_cpu_s']:.3f}"], sec)
    ck.text(group, doc, "rtol = 1e-12 to {} relative: that is its accuracy.",
            [sci(d["continuation_accuracy_rel"], 2, "-")], sec)
    ck.text(group, doc, "({} at the first level", [str(d["max_periods"])], sec)
    ck.text(group, doc, "a budget of {} times the continuation's CPU time. It spent **{} s**",
            [f"{d['budget_factor']:.0f}", f"{d['brute_force_cpu_s']:.3f}"], sec)
    ck.text(group, doc, "the jumps to {} relative, far short",
            [sci(d["brute_force_bracket_rel"], 2, "-")], sec)
    ck.text(group, doc, "the brute force's is {}, an upper bound",
            [f"{d['ratio_continuation_over_brute_force']:.4f}"], sec)
    ck.value(group, "benchmarks/results/continuation_diagram_cost.json",
             "the brute force short of the continuation's accuracy (the ratio a bound)",
             "False", str(d["brute_force_reached_accuracy"]),
             ok=not d["brute_force_reached_accuracy"])
    f = load(result_path("fold_curves.json"))
    ck.value(group, "studies/results/fold_curves.json",
             "every fold curve within one grid step of the sweeps' jumps", "True",
             str(f["all_within_one_step"]), ok=f["all_within_one_step"])
    ck.text(group, "docs/continuation.md", "(approach/retract sweeps in steps of {} at {} values "
            "of α2)", [sci(f["grid_step"], 1, "-"), ["one", "two", "three", "four", "five"]
                       [len(f["brute_force"]) - 1]], "5a. Folds in two parameters")


def check_scan(ck, group="scan"):
    """docs/instrument.md's AM imaging cost and line against benchmarks/results/scan_line.json
    (`python benchmarks/scan_line.py`)."""
    scan = load(result_path("scan_line.json"))
    doc, sec = "docs/instrument.md", "AM imaging"
    ck.text(group, doc, "trace and retrace at 2 Hz, {} periods per pixel) took {} s of CPU for {} scan periods "
            "and {} periods of ring-up", [scan["periods_per_pixel"], f"{scan['cpu_s']:.1f}",
                                           grouped(scan["scan_periods"], ","), grouped(scan["engage_periods"], ",")],
            sec)
    ck.text(group, doc, "({} µs per period", [f"{scan['cpu_us_per_period']:.0f}"], sec)
    ck.text(group, doc, "It shows a step of {} nm for the 5 nm step, the softer material {} nm higher than "
            "polystyrene and a phase contrast of {} deg",
            [f"{scan['apparent_step_nm']:.3f}", f"{scan['apparent_material_step_nm']:.3f}",
             f"{scan['phase_contrast_deg']:.1f}".replace("-", MINUS)], sec)


# ----------------------------------------------------------------------------- main
def check_fm(ck, group="fm"):
    """docs/instrument.md's FM approach against benchmarks/results/fm_approach.json
    (`python benchmarks/fm_approach.py`)."""
    fm = load(result_path("fm_approach.json"))
    doc, sec = "docs/instrument.md", "FM-AFM"
    z = fm["z_nm"]
    one, three = fm["curves"]["1"], fm["curves"]["3"]
    rel = [abs(a / b - 1) for a, b in zip(one["df_Hz"], one["sader_jarvis_Hz"])]
    rel3 = [a / b - 1 for a, b in zip(three["df_Hz"], three["sader_jarvis_Hz"])]
    far = [i for i, v in enumerate(z) if v >= 6 - 1e-9]
    near = [i for i, v in enumerate(z) if abs(v - 5.5) < 1e-9]
    contact = [i for i, v in enumerate(z) if v <= 4.5 + 1e-9]
    ck.text(group, doc, "the integral's within {} down to Z = 6 nm (1 nm above",
            [f"{max(rel[i] for i in far):.1e}"], sec)
    ck.text(group, doc, "the sample) and {} at 5.5 nm; three modes sit {}% below it throughout",
            [f"{rel[near[0]]:.1e}", f"{-sum(rel3[i] for i in far) / len(far) * 100:.2f}"], sec)
    ck.text(group, doc, "Δf rises to {} Hz ({}% of f0)",
            [f"{max(one['df_Hz']):.0f}", f"{max(one['df_Hz']) / one['f0_Hz'] * 100:.1f}"], sec)
    ck.text(group, doc, "differs from the integral by up to {}% (one mode)",
            [f"{max(rel[i] for i in contact) * 100:.1f}"], sec)
    ck.text(group, doc, "Δf still moves by up to\n  {} Hz over the average window",
            [f"{max(one['df_spread_Hz']):.1f}"], sec)
    ck.text(group, doc, "reads up to {} aJ on this", [f"{max(one['dissipation_aJ']):.3f}"], sec)
    ck.text(group, doc, "cost: {} s of CPU for the one-mode curve ({} periods, {} µs per period) against",
            [f"{one['cpu_s']:.1f}", one["periods"], f"{one['us_per_period']:.0f}"], sec)
    ck.text(group, doc, "{} µs per period for tmafm.observe at one fixed Z in the same run ({} times:",
            [f"{one['plain_observe_us_per_period']:.0f}",
             f"{one['us_per_period'] / one['plain_observe_us_per_period']:.2f}"], sec)
    ck.text(group, doc, "{} against {} µs for three modes",
            [f"{three['us_per_period']:.0f}", f"{three['plain_observe_us_per_period']:.0f}"], sec)


GROUPS = {
    "figures": lambda ck: check_figures(ck, load(SUMMARY)),
    "period_search": check_period_search,
    "readme": check_readme,
    "performance": check_performance,
    "docs": check_other_docs,
    "errata": check_errata,
    "am_afm": check_am_afm,
    "continuation": check_continuation,
    "scan": check_scan,
    "fm": check_fm,
}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=list(GROUPS), help="check only these groups")
    parser.add_argument("--list", action="store_true", help="list the groups and stop")
    parser.add_argument("--recompute", action="store_true", help="recompute the deterministic numbers (~20 s)")
    parser.add_argument("--figures", action="store_true",
                        help="rerun python -m tmafm.figures and check reproduction.md against it")
    parser.add_argument("--rerun-timings", action="store_true",
                        help="rerun run_time.py, basin_map.py and period_cost.py and compare their timings")
    parser.add_argument("--timing-factor", type=float, default=1.6)
    parser.add_argument("--quiet", action="store_true", help="print only the drifted claims")
    args = parser.parse_args(argv)
    if args.list:
        print("\n".join(GROUPS))
        return 0
    ck = Checker()
    for name in args.only or GROUPS:
        try:
            if name == "figures" and args.figures:
                check_figures(ck, rerun_figures(ck), group="figures (rerun)")
            else:
                GROUPS[name](ck)
        except NoHistory as error:   # a tarball: the earlier runs' JSON is in git only
            ck.value(name, "git", "the earlier runs the docs quote", "in git history", str(error), ok=False)
    if args.recompute:
        recompute(ck)
    if args.rerun_timings:
        rerun_timings(ck, args.timing_factor)
    return 0 if ck.report(verbose=not args.quiet) else 1


if __name__ == "__main__":
    sys.exit(main())
