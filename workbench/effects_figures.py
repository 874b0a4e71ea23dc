"""Pictures of what each effect does: the steady trail and the pitch-doublet
response with and without it, on the KDC-10 demo case, one PNG per effect,
plus `effects_summary.json` (drogue displacement and doublet response numbers).

    python3 -m workbench.effects_figures [--out docs/effects] [--duration 12]

The baseline is the demo case flown with the wind-tunnel drogue lift (the
paper's model as built; the case file itself flies without lift), each effect
at the typical parameters in `TYPICAL`.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np

from solver.effects import EFFECTS, ORDER
from workbench.cases import load_case
from workbench.simulate import simulate_case

ROOT = Path(__file__).resolve().parent.parent
DEMO = ROOT / "cases" / "demo" / "kdc10_doublet_demo.toml"

# typical in-flight values: what the figures and the summary show
TYPICAL = {
    "tanker_wake": {},
    "drogue_lift": {"scale": 0.5},
    "drogue_drag": {"scale": 1.2},
    "turbulence": {},
    "bow_wave": {},
    "steady_wind": {"vertical_mps": 3.0},
    "gust": {"start_s": 6.0},
    "hose_drag": {"crossflow": 1.3},
    "hose_stiffness": {"bending": 3.0},
    "reel_lag": {},
    "sensor_lag": {"delay_s": 0.1},
    "drogue_reference": {"offset_m": -0.2},
}


def _case(case_path: Path, model_overrides: dict, duration: float):
    case = load_case(case_path)
    tables = dict(case.tables)
    tables["model"] = {**tables["model"], **model_overrides}
    tables["run"] = {**tables["run"], "duration_s": duration}
    return dataclasses.replace(case, tables=tables)


def _run(case, effects: dict, duration: float):
    sim = simulate_case(case, effects=effects, duration=duration, record_dt=0.02)
    return sim.static, sim.result


def _metrics(s0, res) -> dict:
    d = res.drogue_xyz
    settle = res.t > 0.5
    return {
        "drogue_static_xyz_m": [float(v) for v in s0.pos[-1]],
        "drogue_z_peak_to_peak_m": float(np.ptp(d[settle, 2])),
        "drogue_y_peak_to_peak_m": float(np.ptp(d[settle, 1])),
        "tow_tension_static_N": float(np.linalg.norm(res.tow_force[0])),
    }


def effect_figures(out_dir: Path, case_path: Path = DEMO, duration: float = 12.0,
                   effects=None) -> list[Path]:
    """Render one PNG per effect (and the summary JSON) into `out_dir`."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    names = [n for n in ORDER if effects is None or n in effects]
    base_case = _case(case_path, {"drogue_lift_scale": 1.0}, duration)
    drum_case = _case(case_path, {"drogue_lift_scale": 1.0, "reel": "drum"}, duration)
    base = _run(base_case, {}, duration)
    drum_base = None
    summary = {"case": str(case_path), "baseline": "wind-tunnel drogue lift", "duration_s": duration,
               "baseline_metrics": _metrics(*base), "effects": {}}
    paths = []
    for name in names:
        params = TYPICAL[name]
        e = EFFECTS[name]
        if e.comparison_only:
            paths.append(_comparison_figure(out_dir, name, base[1], params, plt))
            summary["effects"][name] = {"params": params, "note": "comparison only: the physics is unchanged"}
            continue
        if name == "reel_lag":
            if drum_base is None:
                drum_base = _run(drum_case, {}, duration)
            b0, b1 = drum_base
            e0, e1 = _run(drum_case, {name: params}, duration)
        else:
            b0, b1 = base
            e0, e1 = _run(base_case, {name: params}, duration)
        mb, me = _metrics(b0, b1), _metrics(e0, e1)
        delta = (np.array(me["drogue_static_xyz_m"]) - mb["drogue_static_xyz_m"]).tolist()
        n = min(len(b1.t), len(e1.t))
        dev = float(np.max(np.linalg.norm(e1.drogue_xyz[:n] - b1.drogue_xyz[:n], axis=1)))
        summary["effects"][name] = {"params": params, "drogue_static_shift_xyz_m": delta,
                                    "drogue_max_deviation_from_baseline_m": dev,
                                    "baseline": mb, "with_effect": me}
        label = f"{name} " + ", ".join(f"{k}={v:g}" for k, v in params.items())
        fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
        ax = axes[0]
        ax.plot(b0.pos[:, 0], b0.pos[:, 2], "k-", label="baseline")
        ax.plot(e0.pos[:, 0], e0.pos[:, 2], "C3-", label=label)
        ax.set_xlabel("x aft of tow point (m)")
        ax.set_ylabel("z up (m)")
        ax.set_title("steady trail, side view (z exaggerated)")
        ax.legend(fontsize=8)
        ax = axes[1]
        ax.plot(b0.pos[:, 0], b0.pos[:, 1], "k-")
        ax.plot(e0.pos[:, 0], e0.pos[:, 1], "C3-")
        ax.set_xlabel("x aft of tow point (m)")
        ax.set_ylabel("y starboard (m)")
        ax.set_title(f"steady trail, top view; drogue moved "
                     f"({delta[0]:+.2f}, {delta[1]:+.2f}, {delta[2]:+.2f}) m")
        ax = axes[2]
        ax.plot(b1.t, b1.drogue_xyz[:, 2] - b0.pos[-1, 2], "k-", label="z, baseline")
        ax.plot(e1.t, e1.drogue_xyz[:, 2] - e0.pos[-1, 2], "C3-", label="z, with effect")
        ax.plot(b1.t, b1.drogue_xyz[:, 1] - b0.pos[-1, 1], "k:", label="y, baseline")
        ax.plot(e1.t, e1.drogue_xyz[:, 1] - e0.pos[-1, 1], "C3:", label="y, with effect")
        if name == "reel_lag":
            ax.plot(b1.t, b1.reel_length - b1.reel_length[0], "k--", label="reel out, baseline")
            ax.plot(e1.t, e1.reel_length - e1.reel_length[0], "C3--", label="reel out, with effect")
        ax.set_xlabel("t (s)")
        ax.set_ylabel("drogue from its own steady position (m)")
        ax.set_title("0.3 m tow-point pitch doublet at 1 s")
        ax.legend(fontsize=7)
        fig.suptitle(f"{e.title} ({name}): KDC-10 pod hose, 254 KCAS, 15 050 ft")
        fig.tight_layout()
        p = out_dir / f"{name}.png"
        fig.savefig(p, dpi=90)
        plt.close(fig)
        paths.append(p)
    sp = out_dir / "effects_summary.json"
    sp.write_text(json.dumps(summary, indent=2) + "\n")
    paths.append(sp)
    if effects is None:
        md = out_dir / "README.md"
        md.write_text(effects_markdown(summary))
        paths.append(md)
    return paths


def effects_markdown(summary: dict | None = None) -> str:
    """The effect library as a document: model, source, parameters (from the
    registry), the picture and, given a summary, the drogue's steady shift."""
    lines = ["# Unmodelled-effect library", "",
             "Every candidate explanation of the paper's flight mismatches as a switchable model "
             "component (`solver/effects.py`). Off unless a case names it (`[effects.NAME]`) or "
             "`workbench run CASE --effect NAME:key=value` turns it on; effects compose. Generated by "
             "`python3 -m workbench.effects_figures` from the registry.", ""]
    if summary:
        b = summary["baseline_metrics"]["drogue_static_xyz_m"]
        lines += [f"Pictures and numbers: the KDC-10 demo case (75 ft pod hose, 254 KCAS, 15 050 ft, "
                  f"410 000 lb) with the wind-tunnel drogue lift, drogue steady at "
                  f"x={b[0]:.2f} y={b[1]:.2f} z={b[2]:.2f} m; a 0.3 m tow-point pitch doublet at 1 s.", "",
                  "| effect | typical parameters | drogue steady shift dx, dy, dz (m) | "
                  "doublet z p-p (m), baseline -> effect | largest drogue difference in the run (m) |",
                  "|---|---|---|---|---|"]
        for name, e in summary["effects"].items():
            pars = ", ".join(f"{k}={v:g}" for k, v in e["params"].items()) or "defaults"
            if "drogue_static_shift_xyz_m" in e:
                d = e["drogue_static_shift_xyz_m"]
                pp = (f"{e['baseline']['drogue_z_peak_to_peak_m']:.2f} -> "
                      f"{e['with_effect']['drogue_z_peak_to_peak_m']:.2f}")
                dev = e["drogue_max_deviation_from_baseline_m"]
                lines.append(f"| {name} | {pars} | {d[0]:+.3f}, {d[1]:+.3f}, {d[2]:+.3f} | {pp} | {dev:.2f} |")
            else:
                lines.append(f"| {name} | {pars} | (comparison only) | | |")
        lines.append("")
    for name in ORDER:
        e = EFFECTS[name]
        lines += [f"## {name}: {e.title}", "", e.model, "", f"Source: {e.source}", "",
                  "| parameter | unit | default | range | meaning |", "|---|---|---|---|---|"]
        for key, p in e.params.items():
            lines.append(f"| {key} | {p.unit} | {p.default:g} | {p.lo:g} .. {p.hi:g} | {p.doc} |")
        lines += ["", f"![{name}]({name}.png)", ""]
    return "\n".join(lines) + "\n"


def _comparison_lines(name: str, res, params: dict) -> tuple[str, list]:
    """A comparison-only effect's picture: the y label and (t, y, style, label)
    lines of the simulated truth and of what the instrument logs of it."""
    if name == "sensor_lag":
        from workbench.effects_compare import restamp
        delay = params["delay_s"]
        z = res.drogue_xyz[:, 2] - res.drogue_xyz[0, 2]
        return "drogue z from steady (m)", [
            (res.t, z, "k-", "drogue (simulated truth)"),
            (res.t + delay, z, "C0--", f"tracker with {delay:g} s latency, as stamped"),
            (restamp(res.t + delay, delay), z, "C3:", "tracker, stamps corrected (sensor_lag)")]
    off = params["offset_m"]
    x = res.drogue_xyz[:, 0]
    return "drogue x aft of tow point (m)", [
        (res.t, x, "k-", "model's drogue centre (simulated truth)"),
        (res.t, x + off, "C0--", f"tracked point, {off:+g} m aft of it (as logged)")]


def _comparison_figure(out_dir: Path, name: str, res, params: dict, plt) -> Path:
    ylabel, lines = _comparison_lines(name, res, params)
    fig, ax = plt.subplots(figsize=(7, 4))
    for t, y, style, label in lines:
        ax.plot(t, y, style, label=label, lw=2 if style.endswith(":") else 1.5)
    ax.set_xlabel("t (s)")
    ax.set_ylabel(ylabel)
    ax.set_xlim(0, min(8.0, float(res.t[-1])))
    ax.set_title(f"{name} acts on the comparison, not the physics")
    ax.legend(fontsize=8)
    fig.tight_layout()
    p = out_dir / f"{name}.png"
    fig.savefig(p, dpi=90)
    plt.close(fig)
    return p


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "effects")
    ap.add_argument("--duration", type=float, default=12.0)
    ap.add_argument("--effect", action="append", help="only these effects (repeatable)")
    a = ap.parse_args(argv)
    for p in effect_figures(a.out, duration=a.duration, effects=a.effect):
        print(p)


if __name__ == "__main__":
    main()
