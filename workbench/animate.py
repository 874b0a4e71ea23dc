"""An animation of a run's hose, over a log's video points where there is one.

A GIF through Pillow (matplotlib's PillowWriter): pure pip, no ffmpeg. Two
views of the tow-point frame: the side (x-z), where the chase-plane video's
hose points are drawn, and the top (x-y), where the tracker's drogue is.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from flighttest import FlightRecord
from solver.result import SimulationResult
from workbench.simlog import VIDEO_DT

FPS = 10          # frames per second of the GIF: the video's rate, so it plays in real time


def _frame_times(result: SimulationResult, record: FlightRecord | None) -> np.ndarray:
    """The log's video frames inside the run, or the run at the video's rate."""
    t0, t1 = float(result.t[0]), float(result.t[-1])
    video = record.topics.get("/video/hose") if record is not None else None
    if video is not None and len(video):
        t = np.unique(video["t_s"].to_numpy(float))
        t = t[(t >= t0) & (t <= t1)]
        if len(t):
            return t
    return np.arange(t0, t1 + 1e-9, VIDEO_DT)


def animate(result: SimulationResult, path: str | Path, record: FlightRecord | None = None,
            title: str = "", fps: int = FPS) -> Path:
    """Write a GIF of the simulated hose (side and top views), with `record`'s
    video hose points and tracker fixes at the same times; return the path."""
    from matplotlib.animation import FuncAnimation, PillowWriter
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    times = _frame_times(result, record)
    k = np.clip(np.searchsorted(result.t, times), 0, len(result.t) - 1)
    video = record.topics.get("/video/hose") if record is not None else None
    fixes = record.tracker_fixes() if record is not None and len(record.topics.get("/ors/drogue", ())) else None

    fig = Figure(figsize=(8, 6), layout="constrained")
    FigureCanvasAgg(fig)
    side, top = fig.subplots(2, 1, sharex=True)
    pts = result.hose_xyz[k].reshape(-1, 3)
    pad = 1.0
    side.set(xlim=(np.nanmin(pts[:, 0]) - pad, np.nanmax(pts[:, 0]) + pad), ylabel="z up (m)",
             title="side view (x-z)")
    z = pts[:, 2] if video is None else np.concatenate([pts[:, 2], video["z_m"].to_numpy(float)])
    side.set_ylim(np.nanmin(z) - pad, np.nanmax(z) + pad)
    y = pts[:, 1] if fixes is None else np.concatenate([pts[:, 1], fixes["y_m"].to_numpy(float)])
    top.set(ylim=(np.nanmin(y) - pad, np.nanmax(y) + pad), xlabel="x aft of the tow point (m)",
            ylabel="y starboard (m)", title="top view (x-y)")
    sim_side, = side.plot([], [], "-", color="tab:blue", lw=2, label="simulation")
    sim_top, = top.plot([], [], "-", color="tab:blue", lw=2, label="simulation")
    vid, = side.plot([], [], "o", color="k", ms=4, label="video points")
    drg, = top.plot([], [], "o", color="tab:orange", ms=8, label="tracker drogue")
    for ax in (side, top):
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)   # outside the data
    stamp = fig.suptitle("")
    video_t = np.unique(video["t_s"].to_numpy(float)) if video is not None else None

    def draw(i):
        p = result.hose_points(k[i])
        sim_side.set_data(p[:, 0], p[:, 2])
        sim_top.set_data(p[:, 0], p[:, 1])
        if video_t is not None and len(video_t):
            tv = video_t[np.argmin(np.abs(video_t - times[i]))]
            g = video[video["t_s"] == tv]
            vid.set_data(g["x_m"], g["z_m"])
        if fixes is not None and len(fixes):
            j = int(np.argmin(np.abs(fixes.index.to_numpy(float) - times[i])))
            drg.set_data([fixes["x_m"].iloc[j]], [fixes["y_m"].iloc[j]])
        stamp.set_text(f"{title}  t = {times[i]:.2f} s".strip())
        return sim_side, sim_top, vid, drg, stamp

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    FuncAnimation(fig, draw, frames=len(times), blit=False).save(path, writer=PillowWriter(fps=fps))
    return path
