"""The run plot without matplotlib: the figure model (nice ticks, equal aspect), its PNG
drawn by Pillow (size, each line's pixels where its data says, crisp marks, dashes), the
fields read from the series' JSON, and the same figure through matplotlib for SVG."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from navkit import figure, figure_png, plot

_TRUTH, _MICRO, _COMMAND, _EVENT = (31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40)


def _series(n: int = 200, cmds=(({"fwd_cmd": 1, "speed": 300, "distance": 300}, 5.0),),
            events=(("unplug", 8.0),)) -> dict:
    """RunSeries.raw() of a 20-s run: /truth and /micro/data every 0.1 s (a straight path
    up, 100 mm/s, heading 3 deg/s), commands and events at the given times (s)."""
    def enc(obj):
        return json.dumps(obj, separators=(",", ":")).encode()

    truth = [(i * 100_000_000, enc({"t": i / 10, "x_mm": 10.0 * i, "y_mm": float(i % 7), "yaw_deg": 0.0,
                                    "heading_deg": 3.0 * i / 10, "v_mm_s": 100.0,
                                    "servo_deg": [0.0, 1.0]})) for i in range(n)]
    micro = [(i * 100_000_000, enc({"time_tag": i, "fwd_speed": 50, "heading": 30 * i // 10,
                                    "x": 10 * i, "y": 0, "adc": [1, 2]})) for i in range(n)]
    return {"/truth": truth, "/micro/data": micro,
            "/planner/cmd": [(round(t * 1e9), enc(c)) for c, t in cmds],
            "/events": [(round(t * 1e9), enc({"t": t, "kind": k, "detail": {}})) for k, t in events]}


def _near(img: np.ndarray, x: float, y: float, rgb: tuple, reach: int = 1, tol: int = 40) -> bool:
    """Whether a pixel within `reach` of page point (x, y) has colour `rgb` (within `tol`
    per channel)."""
    c, r = math.floor(x), math.floor(y)
    box = img[r - reach:r + reach + 1, c - reach:c + reach + 1].astype(int)
    return bool((np.abs(box - np.array(rgb)).max(axis=2) <= tol).any())


@pytest.mark.parametrize("lo_hi_most", [(1742.8, -2220.5, 9), (-1.2, 25.2, 9), (-5, 365, 9),
                                        (0.1, 1.1, 1), (1000, 1000.1, 9)])
def test_nice_ticks_known_axes(lo_hi_most):
    """Steps as matplotlib's locator picks them for the axes of the demo's plot."""
    lo, hi, most = lo_hi_most
    ticks = figure.nice_ticks(lo, hi, most)
    expect = {1742.8: 500, -1.2: 5, -5: 50, 0.1: 0.5, 1000: 0.02}[lo]
    assert np.allclose(np.diff(ticks), expect), ticks


def test_nice_ticks_are_nice_and_cover_the_limits(prop_seed, prop_count):
    """Random limits over 30 decades: ticks evenly spaced by 1, 2, 2.5 or 5 x 10^n, all
    within the limits, at least 2 and at most `most` + 1 of them (or the step is the
    smallest that gives 2), none missing at either end (less than a step left over), and
    their labels distinct and read back to the ticks."""
    rng = np.random.default_rng(prop_seed)
    for _ in range(prop_count):
        scale = 10.0 ** rng.uniform(-12, 12)
        lo = rng.uniform(-1, 1) * scale * rng.choice([1, 100])
        hi = lo + rng.uniform(0.01, 10) * scale
        most = int(rng.integers(1, 10))
        ticks = figure.nice_ticks(lo, hi, most)
        case = (prop_seed, lo, hi, most, ticks)
        assert ticks.size >= 2, case
        step = ticks[1] - ticks[0]
        assert np.allclose(np.diff(ticks), step, rtol=1e-6), case
        mant = step / 10.0 ** math.floor(math.log10(step) + 1e-9)
        assert min(abs(mant - m) for m in (1, 2, 2.5, 5, 10)) < 1e-6, case
        slack = 1e-6 * step
        assert lo - slack <= ticks[0] < lo + step and hi - step < ticks[-1] <= hi + slack, case
        assert ticks.size <= most + 1 or step <= (hi - lo) / most, case
        labels = figure.tick_labels(ticks)
        assert len(set(labels)) == len(labels), (case, labels)
        back = [float(s.replace("\u2212", "-")) for s in labels]
        assert np.allclose(back, ticks, rtol=1e-6, atol=1e-9 * abs(step)), (case, labels)


def test_equal_aspect_widens_one_axis_about_its_centre():
    """A tall narrow path in a wide box: x is widened about its centre until a mm is as
    long across as up; y keeps its margined data limits; x is inverted."""
    p = figure.Panel((0.1, 0.5, 0.8, 0.3), invert_x=True, equal=True)
    p.lines.append(figure.Line(np.array([0.0, 10.0]), np.array([0.0, 1000.0]), "#000000"))
    fig = figure.Figure(9, 11, 110, [p]).finish()
    (x_left, x_right), (y0, y1) = p.xlim, p.ylim
    assert x_left > x_right, "inverted x"
    assert (y0, y1) == pytest.approx((-50.0, 1050.0))
    w_pt, h_pt = p.size_pt(fig)
    assert (x_left - x_right) / w_pt == pytest.approx((y1 - y0) / h_pt)
    assert (x_left + x_right) / 2 == pytest.approx(5.0)
    assert p.xticks.min() >= x_right and p.xticks.max() <= x_left


def test_run_png_has_each_line_where_its_data_says(tmp_path):
    """The run plot's PNG: 990 x 1210 at 110 dpi; the truth's and the micro's colours at
    the pixels of known points of the path and speed panels, the command's green and the
    event's red across the speed panel at their times, white between; the same PNG bytes
    for the same series."""
    fig = plot.run_figure(_series(), "t/run.mcap: path")
    out = tmp_path / "p.png"
    figure_png.write_png(fig, out)
    with Image.open(out) as im:
        assert im.size == (990, 1210) and [round(d) for d in im.info["dpi"]] == [110, 110]
        img = np.asarray(im.convert("RGB"))
    xy, v, h = fig.panels
    # the path's last truth point (y 3 mm left, x 1990 mm up) and a micro point (y 0, x 1000)
    px, py = figure_png.to_pixels(fig, xy, [199 % 7], [1990.0])
    assert _near(img, px[0], py[0], _TRUTH), (px, py)
    px, py = figure_png.to_pixels(fig, v, [10.0], [100.0])      # truth speed at 10 s
    assert _near(img, px[0], py[0], _TRUTH)
    px, py = figure_png.to_pixels(fig, v, [10.0], [50.0])       # micro fwd_speed at 10 s
    assert _near(img, px[0], py[0], _MICRO, tol=90)        # 0.8 pt: blended over two rows
    _, top, _, bottom = figure_png.panel_box(fig, v)
    for t, rgb in ((5.0, _COMMAND), (8.0, _EVENT)):
        px, _ = figure_png.to_pixels(fig, v, [t], [0.0])
        hits = sum(_near(img, px[0], y, rgb, reach=0, tol=90) for y in range(top + 40, bottom - 40))
        assert hits > 0.25 * (bottom - top - 80), (t, hits)
    px, py = figure_png.to_pixels(fig, v, [15.0], [250.0])      # nothing drawn there
    assert (img[math.floor(py[0]), math.floor(px[0])] == 255).all()
    again = tmp_path / "again.png"
    figure_png.write_png(plot.run_figure(_series(), "t/run.mcap: path"), again)
    assert again.read_bytes() == out.read_bytes()


def test_marks_are_crisp_and_dashes_measure_their_pattern():
    """A command's mark covers whole pixel columns (no smear over a neighbour); a dashed
    line's pieces are `on` long with `off` gaps along the line, the last one cut at its end."""
    xs, ys = np.array([0.0, 30.0, 30.0]), np.array([0.0, 0.0, 25.0])
    px, py, bounds = figure_png._dashes(xs, ys, 4.0, 2.0)
    lengths = [np.hypot(np.diff(px[a:b]), np.diff(py[a:b])).sum() for a, b in zip(bounds, bounds[1:])]
    assert lengths[:-1] == pytest.approx([4.0] * (len(lengths) - 1)) and 0 < lengths[-1] <= 4.0
    assert len(lengths) == math.ceil(55 / 6) and px[0] == 0 and (px[-1], py[-1]) == (30.0, 25.0)
    from PIL import ImageDraw

    canvas = Image.new("RGB", (30 * 3, 9), (255, 255, 255))      # 30 x 3 page pixels at 3x
    figure_png._draw_marks(canvas, ImageDraw.Draw(canvas), [13.7 * 3], 1.2 * 3, "solid", (0, 0, 0), 3)
    page = np.asarray(canvas.reduce(3))
    assert np.flatnonzero((page < 255).any(axis=(0, 2))).tolist() == [13] and (page[:, 13] == 0).all()


def test_fields_read_from_the_text_as_json_decodes_them():
    """fields(): the values found by each key's text are json's; a key that is nested
    too or missing falls back to decoding (same values, or an error naming topic and
    key); messages out of log-time order come back in order."""
    s = _series(50)
    t, got = plot.fields("/truth", s["/truth"], ("t", "x_mm", "heading_deg"))
    dec = [m for _, m in plot.decoded({"/truth": s["/truth"]})["/truth"]]
    assert t.tolist() == [m["t"] for m in dec]
    assert got["x_mm"].tolist() == [m["x_mm"] for m in dec]
    nested = [(ns, b'{"x":%d,"inner":{"x":-1}}' % i) for i, (ns, _) in enumerate(s["/truth"])]
    shuffled = nested[1:] + nested[:1]
    t, got = plot.fields("/micro/data", shuffled, ("x",))
    assert got["x"].tolist() == list(range(50)) and (np.diff(t) > 0).all()
    with pytest.raises(ValueError, match=r"/micro/data.*'y'"):
        plot.fields("/micro/data", nested, ("y",))


def test_png_bytes_hold_the_pixels():
    """The PNG writer (rows stored as differences from the row above) decodes with Pillow
    to the very pixels given, RGB and RGBA, at the dpi given."""
    import io

    rng = np.random.default_rng(1)
    for channels, mode in ((3, "RGB"), (4, "RGBA")):
        pixels = rng.integers(0, 256, size=(37, 23, channels), dtype=np.uint8)
        pixels[5:9] = 255                                      # rows alike, as in a plot
        with Image.open(io.BytesIO(figure_png.png_bytes(pixels, 110))) as im:
            assert im.mode == mode and im.size == (23, 37)
            assert [round(d) for d in im.info["dpi"]] == [110, 110]
            assert np.array_equal(np.asarray(im), pixels)


def test_png_plot_needs_no_matplotlib(tmp_path):
    """The run plot's PNG is drawn without importing matplotlib, in DejaVu Sans from
    matplotlib's package data (found by its spec, not its import)."""
    (tmp_path / "s.json").write_text(json.dumps({k: [(t, d.decode()) for t, d in v]
                                                 for k, v in _series().items()}))
    code = ("import json, sys; from pathlib import Path; from navkit import figure_png, plot\n"
            "raw = {k: [(t, d.encode()) for t, d in v] for k, v in json.load(open(sys.argv[1])).items()}\n"
            "plot.plot_mcap(Path('r/run.mcap'), sys.argv[2], raw)\n"
            "print(figure_png.font_path(), 'matplotlib' in sys.modules)\n")
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "s.json"), str(tmp_path / "p.png")],
                          capture_output=True, text=True, check=True)
    font, imported = done.stdout.split()
    assert font.endswith("DejaVuSans.ttf") and imported == "False", done.stdout
    with Image.open(tmp_path / "p.png") as im:
        assert im.size == (990, 1210)


def test_svg_draws_the_same_figure(tmp_path):
    """-o x.svg: matplotlib draws the model: its lines in their colours, the limits and
    ticks the model set, the command and event marks as collections."""
    from navkit.figure_mpl import save, to_matplotlib

    fig = plot.run_figure(_series(), "t/run.mcap: path")
    mfig = to_matplotlib(fig)
    for ax, p in zip(mfig.axes, fig.panels):
        assert ax.get_xlim() == pytest.approx(p.xlim) and ax.get_ylim() == pytest.approx(p.ylim)
        assert ax.get_xticks() == pytest.approx(p.xticks)
    marks = {c.get_gid(): [seg[0][0] for seg in c.get_segments()] for c in mfig.axes[1].collections}
    assert marks == {"command": [5.0], "event": [8.0]}
    save(fig, tmp_path / "p.svg", "svg")
    svg = (tmp_path / "p.svg").read_text()
    assert svg.count("stroke: #1f77b4") >= 2 and "stroke: #ff7f0e" in svg, "truth and micro lines"
    assert "fill: #1f77b4" in svg, "the truth heading's dots"


def test_labels_stand_apart_inside_the_panel():
    """Many commands, most after the truth ends: only those inside the speed panel's time
    limits are labelled, two label heights (12 pt) apart at least; every one keeps its
    mark."""
    cmds = [({"fwd_cmd": 1}, k / 7) for k in range(5000)]
    fig = plot.run_figure(_series(20, cmds=cmds), "t")
    v = fig.panels[1]
    xs = [u.x for u in v.labels]
    lo, hi = sorted(v.xlim)
    per_s = v.size_pt(fig)[0] / (hi - lo)
    assert xs and all(lo <= x <= hi for x in xs)
    assert min(np.diff(xs)) * per_s >= 12 - 1e-9 and len(xs) <= v.size_pt(fig)[0] / 12 + 1
    assert len(v.marks[0].x) == 5000


def test_dots_outside_the_box_are_cut_off():
    """A dot beyond the panel's left edge is not drawn at all (not wrapped to the other
    side of the row above); one inside is."""
    canvas = Image.new("RGB", (60, 30), (255, 255, 255))
    figure_png._draw_dots(canvas, np.array([-4.0, 31.0, np.nan]), np.array([15.0, 15.0, 1.0]), 4.5,
                          (0, 0, 0), 3)
    inked = np.argwhere((np.asarray(canvas) < 255).any(axis=2))
    assert inked.size and inked[:, 1].min() >= 31 - 5 and inked[:, 1].max() <= 31 + 5


@pytest.mark.parametrize("topic, msg, said", [
    ("/events", {"t": 8.0, "detail": {}}, "KeyError: 'kind'"),
    ("/planner/cmd", [1, 2], "AttributeError"),
    ("/planner/cmd", {"turn_mode": 1, "turn_distance": "90"}, "TypeError"),
])
def test_a_mark_without_its_label_is_an_error_naming_its_topic(topic, msg, said):
    """A command or event message its label cannot be made of (no kind, not an object, a
    field of another type) is a ValueError naming its topic, which `navkit plot` prints
    in one line, not a traceback."""
    s = _series()
    s[topic] = [(5_000_000_000, json.dumps(msg).encode())]
    with pytest.raises(ValueError, match=f"^{topic}: a message the plot cannot label") as e:
        plot.run_figure(s, "t")
    assert said in str(e.value), e.value
