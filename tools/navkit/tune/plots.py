"""The tuner's figures: fit.png (records against the models, residuals), bode.png (open
loops of the design, designed and quantised gains), step.png (predicted against
co-simulated responses)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["fit_png", "bode_png", "step_png"]


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def fit_png(out: Path, fits: list) -> None:
    """fits: [(experiment.Record, {kind: ident.Fit})]: per record its experiments one after
    the other (1 s apart), the measured speed and each model's output (top) with the duty,
    the residuals (bottom)."""
    plt = _plt()
    fig, axes = plt.subplots(2, len(fits), figsize=(7 * len(fits), 6), squeeze=False, sharex="col")
    for j, (rec, by_kind) in enumerate(fits):
        ax, ar = axes[0][j], axes[1][j]
        ax2 = ax.twinx()
        t_at, off = [], 0.0
        for sg in rec.segments:
            t_at.append(off + sg.at * rec.ts)
            ax2.step(off + np.arange(len(sg.u)) * rec.ts, sg.u, "C7", where="post", lw=0.8, alpha=0.6)
            off += len(sg.u) * rec.ts + 1.0
        t = np.concatenate(t_at)
        y = np.concatenate([sg.y for sg in rec.segments])
        ax.plot(t, y, "k.", ms=3, label="measured speed")
        for kind, f in by_kind.items():
            ax.plot(t, f.y_model, ".", ms=2, label=f"{kind} (NRMSE {f.nrmse:.3f})")
            ar.plot(t, y - f.y_model, ".", ms=2, label=kind)
        ax2.set_ylabel("duty (1)")
        how = "replayed steps" if all(rec.replayed) else "duty held between samples"
        ax.set_title(f"{rec.wheel} wheel: {len(rec.segments)} experiment(s), {how}, "
                     f"samples every {rec.sample_period_s * 1000:.0f} ms", fontsize=9)
        ax.set_ylabel("speed (mm/s)")
        ax.legend(loc="upper left", fontsize=8)
        ar.set_ylabel("residual (mm/s)")
        ar.set_xlabel("t (s, experiments 1 s apart)")
        ar.axhline(0, color="k", lw=0.5)
        ar.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)


def bode_png(out: Path, loops: list, title: str) -> None:
    """loops: [(label, discrete open loop)]: magnitude (dB) and phase (deg) to Nyquist."""
    plt = _plt()
    fig, (am, ap) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    for label, loop in loops:
        w = np.geomspace(0.5, 0.99 * np.pi / loop.dt, 800)
        h = np.array([complex(loop(np.exp(1j * x * loop.dt))) for x in w])
        f = w / (2 * np.pi)
        am.semilogx(f, 20 * np.log10(np.abs(h)), label=label)
        ap.semilogx(f, np.degrees(np.unwrap(np.angle(h))), label=label)
    am.axhline(0, color="k", lw=0.5)
    ap.axhline(-180, color="k", lw=0.5)
    am.set_ylabel("|L| (dB)")
    ap.set_ylabel("phase (deg)")
    ap.set_xlabel("frequency (Hz)")
    am.set_title(title)
    am.legend(fontsize=8)
    am.grid(True, which="both", alpha=0.3)
    ap.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)


def step_png(out: Path, curves: list, title: str, ylabel: str, table: str = "") -> None:
    """curves: [(label, t s, y)] on one axis beside a text table of their step figures."""
    plt = _plt()
    fig, (ax, at) = plt.subplots(1, 2, figsize=(12, 5), gridspec_kw={"width_ratios": [3, 2]})
    for label, t, y in curves:
        ax.plot(t, y, label=label)
    ax.set_xlabel("t (s)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    at.axis("off")
    at.text(0.0, 1.0, table, va="top", family="monospace", fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
