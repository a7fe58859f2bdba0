"""Draw a finished navkit.figure.Figure with matplotlib: for the formats other than PNG
(SVG, PDF, ...) and for callers that want matplotlib's objects.

The figure's limits, ticks and tick labels are set as the model has them (matplotlib's
own autoscaling, aspect and tick location are not used), so the drawing matches the PNG
of navkit.figure_png. Imported only when needed: matplotlib's import costs more than a
whole PNG drawing, so the PNG path never pays it.
"""

from __future__ import annotations

__all__ = ["to_matplotlib", "save"]

_LINESTYLE = {"solid": "-", "dashed": "--"}


def to_matplotlib(fig):
    """Finished Figure `fig` as a matplotlib Figure (drawn by Agg, no pyplot): one Axes per
    panel in order, each panel's lines in order as Line2D (labelled for the legend), its
    marks as one LineCollection per Marks (gid set) and its upright labels as annotations."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.collections import LineCollection
    from matplotlib.figure import Figure

    out = Figure(figsize=(fig.width, fig.height), dpi=fig.dpi)
    for p in fig.panels:
        ax = out.add_axes(p.rect)
        for m in p.marks:
            segs = [((x, 0.0), (x, 1.0)) for x in m.x]
            ax.add_collection(LineCollection(segs, transform=ax.get_xaxis_transform(), gid=m.gid,
                                             colors=m.color, linewidths=m.width, alpha=m.alpha,
                                             linestyles=":" if m.style == "dotted" else "solid"),
                              autolim=False)
        for ln in p.lines:
            style = (dict(linestyle="none", marker="o", markersize=ln.width, markeredgewidth=0)
                     if ln.style == "points"
                     else dict(linestyle=_LINESTYLE[ln.style], linewidth=ln.width))
            ax.plot(ln.x, ln.y, color=ln.color, label=ln.label, **style)
        ax.set_xlim(*p.xlim)
        ax.set_ylim(*p.ylim)
        ax.set_xticks(p.xticks, p.xtick_labels)
        ax.set_yticks(p.yticks, p.ytick_labels)
        ax.set_xlabel(p.xlabel)
        ax.set_ylabel(p.ylabel)
        if p.title:
            ax.set_title(p.title, loc="left")
        for u in p.labels:
            ax.annotate(u.text, (u.x, 1.0 if u.at == "top" else 0.0),
                        xycoords=("data", "axes fraction"), rotation=90, ha="right",
                        va="top" if u.at == "top" else "bottom", fontsize=u.size, color=u.color)
        if p.legend and any(ln.label for ln in p.lines):
            ax.legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), ncols=2, fontsize="small",
                      frameon=False, borderaxespad=0.2)
    return out


def save(fig, out, fmt: str) -> None:
    """Finished Figure `fig` written into `out` in matplotlib format `fmt` ("svg", "pdf", ...)."""
    to_matplotlib(fig).savefig(out, dpi=fig.dpi, format=fmt)
