"""Regenerate the paper's Figs. 2-7 from inputs/, laid out like the paper, each with the
paper's scheme (rk4_paper) and with a located, error-controlled method (flight_exact), in
the `paper` convention; Figs. 2 and 6 also in `consistent`.  Also writes summary.json with
the analysis of every case (tmafm.analysis.summary) and the basin scan of Figs. 4-5.

    python -m tmafm.figures --out docs/figures [--inputs FOLDER] [--periods 100] [--basin 41]

The inputs are the packaged ones (tmafm.inputs) unless --inputs names a folder.

Each run covers max(its own tau_end, `periods` drive periods), sampled 200 times a period;
the analysis uses the second half of the run.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from . import analysis
from . import inputs as packaged
from ._extras import require
from ._run import Config
from ._safefile import save_figure, write_text

__all__ = ["main", "METHODS", "CASES"]

#: method name -> solver settings
METHODS = {"rk4_paper": {"method": "rk4_paper"},
           "flight_exact": {"method": "flight_exact", "rtol": 1e-9, "atol": 1e-15}}
#: figure -> (inputs, conventions)
CASES = {
    "fig2": (["fig2_n1", "fig2_n2", "fig2_n3", "fig2_n4"], ["paper", "consistent"]),
    "fig3": (["fig3"], ["paper"]),
    "fig4": (["fig4a", "fig4c"], ["paper"]),
    "fig5": (["fig5a", "fig5c"], ["paper"]),
    "fig6": (["fig6"], ["paper", "consistent"]),
    "fig7": (["fig7_hertz", "fig7_dmt"], ["paper"]),
}


def simulate(inputs: Path | None, name: str, method: str, convention: str, periods: int, **extra):
    """One case, long enough for `periods` drive periods, 200 samples a period."""
    path = packaged.path(name) if inputs is None else inputs / f"{name}.nml"
    base = Config(path)
    period = 2 * math.pi / base.scene["omega"]
    tau_end = max(float(base.to_dict()["solver"]["tau_end"]), periods * period)
    tau_end = math.ceil(tau_end / period - 1e-9) * period
    groups = {"model": {"convention": convention}, "solver": {**METHODS[method], "tau_end": tau_end},
              "output": {"sample_dtau": period / 200}}
    for group, values in extra.items():
        groups.setdefault(group, {}).update(values)
    # From the file, not from `base`: a resolved Config pins `errata` (to the input's
    # convention's default), so a convention override on it would keep the old errata.
    return Config(path, **groups).run()


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    return x


def _last(result, periods=3):
    period = analysis.drive_period(result)
    return result.tau >= result.tau[-1] - periods * period


def _series(ax, result, label, periods=3, **kw):
    keep = _last(result, periods)
    ax.plot(result.tau[keep], result.vt[keep], label=label, **kw)


def _portrait(ax, result, label, periods=3, **kw):
    keep = _last(result, periods)
    ax.plot(result.vt[keep], result.vtdot[keep], label=label, **kw)


def _label_axes(ax_t, ax_p):
    ax_t.axhline(0, color="0.6", lw=0.8)
    ax_t.set_xlabel(r"$\tau$ (units of $\sqrt{mL^4/E_1I}$)")
    ax_t.set_ylabel(r"$V_T$ (units of the gap $d$)")
    ax_p.axvline(0, color="0.6", lw=0.8)
    ax_p.set_xlabel(r"$V_T$ (gap units)")
    ax_p.set_ylabel(r"$\dot V_T$ (gap units per $\tau$)")
    for ax in (ax_t, ax_p):
        ax.grid(True, alpha=0.3)
        ax.ticklabel_format(axis="both", style="sci", scilimits=(-3, 3))


def make_figures(inputs: Path, out: Path, periods: int, basin_points: int, progress=print) -> dict:
    matplotlib = require("matplotlib", "tmafm.figures")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    summary = {"periods": periods, "methods": METHODS, "cases": {}}

    def record(fig_name, name, method, convention, result):
        key = f"{name}/{method}/{convention}"
        summary["cases"][key] = _jsonable(analysis.summary(result))
        return key

    for method in METHODS:
        # Fig. 2: N = 1..4, time series and phase portraits.
        for convention in CASES["fig2"][1]:
            fig, (ax_t, ax_p) = plt.subplots(1, 2, figsize=(11, 4))
            for name in CASES["fig2"][0]:
                r = simulate(inputs, name, method, convention, periods)
                record("fig2", name, method, convention, r)
                label = f"N = {r.n_modes}"
                _series(ax_t, r, label)
                _portrait(ax_p, r, label)
            _label_axes(ax_t, ax_p)
            ax_t.legend()
            fig.suptitle(f"Fig. 2: convergence in N (Hertz, alpha2 = 5e-4), last 3 periods; {method}, {convention}")
            fig.tight_layout()
            save_figure(fig, out / f"fig2_{method}_{convention}.png", dpi=100)
            plt.close(fig)
            progress(f"fig2 {method} {convention}")

        # Fig. 3: modal amplitudes in and out of contact, N = 4.
        r = simulate(inputs, "fig3", method, "paper", periods)
        record("fig3", "fig3", method, "paper", r)
        amps = analysis.modal_amplitudes(r, since=r.tau[-1] / 2)
        fig, axes = plt.subplots(1, 2, figsize=(11, 4))
        modes = np.arange(1, r.n_modes + 1)
        for ax, phase, title in ((axes[0], "contact", "(a) in contact"), (axes[1], "free", "(b) out of contact")):
            if amps[phase]:
                ax.bar(modes - 0.2, amps[phase]["max_abs"], 0.4, label="max |a_j|")
                ax.bar(modes + 0.2, amps[phase]["half_peak_to_peak"], 0.4, label="(max a_j - min a_j)/2")
            ax.set_yscale("log")
            ax.set_xlabel("mode j")
            ax.set_ylabel("modal amplitude (gap units)")
            ax.set_title(title)
            ax.legend()
            ax.grid(True, alpha=0.3)
        fig.suptitle(f"Fig. 3: modal amplitudes, N = 4, second half of the run; {method}, paper")
        fig.tight_layout()
        save_figure(fig, out / f"fig3_{method}_paper.png", dpi=100)
        plt.close(fig)
        progress(f"fig3 {method}")

        # Figs. 4 and 5: two initial conditions each, time series and phase portraits.
        for fig_name in ("fig4", "fig5"):
            names = CASES[fig_name][0]
            fig, axes = plt.subplots(2, 2, figsize=(11, 7))
            for row, name in zip(axes, names):
                r = simulate(inputs, name, method, "paper", periods)
                record(fig_name, name, method, "paper", r)
                a1 = float(np.atleast_1d(r.resolved["initial"]["a0"])[0])
                cls = summary["cases"][f"{name}/{method}/paper"]["classification"]
                _series(row[0], r, None, periods=4, color="tab:blue")
                _portrait(row[1], r, None, periods=4, color="tab:blue")
                _label_axes(row[0], row[1])
                row[0].set_title(f"a1(0) = {a1:g}: {cls}")
            fig.suptitle(f"Fig. {fig_name[3:]}: N = 3, last 4 periods; {method}, paper")
            fig.tight_layout()
            save_figure(fig, out / f"{fig_name}_{method}_paper.png", dpi=100)
            plt.close(fig)
            progress(f"{fig_name} {method}")

        # Fig. 6: DMT, the whole run and the steady state.
        for convention in CASES["fig6"][1]:
            r = simulate(inputs, "fig6", method, convention, periods)
            record("fig6", "fig6", method, convention, r)
            fig, (ax_all, ax_t, ax_p) = plt.subplots(1, 3, figsize=(15, 4))
            ax_all.plot(r.tau, r.vt, lw=0.6)
            ax_all.axhline(0, color="0.6", lw=0.8)
            ax_all.set_xlabel(r"$\tau$")
            ax_all.set_ylabel(r"$V_T$ (gap units)")
            ax_all.set_title("whole run")
            ax_all.grid(True, alpha=0.3)
            _series(ax_t, r, None, periods=2)
            _portrait(ax_p, r, None, periods=2)
            _label_axes(ax_t, ax_p)
            ax_t.set_title("steady state (last 2 periods)")
            fig.suptitle(f"Fig. 6: DMT, alpha2 = 5e-4; {method}, {convention}")
            fig.tight_layout()
            save_figure(fig, out / f"fig6_{method}_{convention}.png", dpi=100)
            plt.close(fig)
            progress(f"fig6 {method} {convention}")

        # Fig. 7: Hertz against DMT at alpha2 = 1e-3.
        fig, (ax_t, ax_p) = plt.subplots(1, 2, figsize=(11, 4))
        for name, color in zip(CASES["fig7"][0], ("tab:blue", "tab:red")):
            r = simulate(inputs, name, method, "paper", periods)
            record("fig7", name, method, "paper", r)
            law = r.resolved["model"]["contact_law"]
            _series(ax_t, r, law, periods=4, color=color)
            _portrait(ax_p, r, law, periods=4, color=color)
        _label_axes(ax_t, ax_p)
        ax_t.legend()
        fig.suptitle(f"Fig. 7: Hertz and DMT, alpha2 = 1e-3, last 4 periods; {method}, paper")
        fig.tight_layout()
        save_figure(fig, out / f"fig7_{method}_paper.png", dpi=100)
        plt.close(fig)
        progress(f"fig7 {method}")

    if basin_points:
        summary["basin"] = basin_scan(inputs, out, periods, basin_points, progress)
    write_text(out / "summary.json", json.dumps(_jsonable(summary), indent=1))
    return summary


def basin_scan(inputs: Path, out: Path, periods: int, points: int, progress=print) -> dict:
    """Figs. 4-5: classify the steady state for a1(0) on a fine grid in [0, 1e-3], with the
    located method, in both conventions."""
    matplotlib = require("matplotlib", "tmafm.figures")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    grid = np.linspace(0.0, 1e-3, points)
    scan = {"a1_0": grid.tolist(), "method": "flight_exact", "rows": {}}
    fig, ax = plt.subplots(figsize=(8, 3.5))
    for convention, marker in (("paper", "o"), ("consistent", "s")):
        rows = []
        for a1 in grid:
            r = simulate(inputs, "fig4a", "flight_exact", convention, periods,
                         initial={"a0": [float(a1), 0.0, 0.0]})
            s = analysis.summary(r)
            rows.append({"a1_0": float(a1), "classification": s["classification"],
                         "vt_min": s["vt_min"], "contact_fraction": s["contact_fraction"]})
        scan["rows"][convention] = rows
        ax.plot(grid, [r["vt_min"] for r in rows], marker, label=convention)
        progress(f"basin {convention}")
    ax.set_xlabel("a1(0) (gap units)")
    ax.set_ylabel("steady min V_T (gap units)")
    ax.set_title("Figs. 4-5 basin scan: the steady state reached from a1(0), N = 3, flight_exact")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    save_figure(fig, out / "basin_fig4_5.png", dpi=100)
    plt.close(fig)
    scan["attractors"] = {c: sorted({r["classification"] for r in rows}) for c, rows in scan["rows"].items()}
    return scan


def main(argv=None) -> None:
    """Command line: regenerate the figures and summary.json."""
    if argv is not None and (isinstance(argv, (str, bytes)) or not isinstance(argv, (list, tuple))
                             or not all(isinstance(a, str) for a in argv)):
        from .errors import InputTypeError
        raise InputTypeError(f"argv must be a list of strings or None, not {type(argv).__name__}")
    parser = argparse.ArgumentParser(description="Regenerate the paper's Figs. 2-7")
    parser.add_argument("--out", type=Path, default=Path("docs/figures"))
    parser.add_argument("--inputs", type=Path, default=None,
                        help="folder of the figure inputs (default: the packaged inputs)")
    parser.add_argument("--periods", type=int, default=100, help="drive periods per run (at least)")
    parser.add_argument("--basin", type=int, default=41, help="points of the a1(0) scan (0: none)")
    args = parser.parse_args(argv)
    make_figures(args.inputs, args.out, args.periods, args.basin)
    print(f"wrote the figures and summary.json to {args.out}")


if __name__ == "__main__":
    main()
