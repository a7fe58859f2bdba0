"""Draw a finished navkit.figure.Figure as a PNG with Pillow (no matplotlib).

Each panel's lines and marks are drawn SCALE times larger than the page and shrunk
(Image.reduce, a box filter): antialiased lines of fractional widths at Pillow's cost of
aliased ones. The panel's image is its box, so what lies outside is cut off there.
Spines, ticks and text are drawn at the page's size (text by FreeType, antialiased) in
DejaVu Sans, the font matplotlib ships, found without importing matplotlib; Pillow's
own font if it is absent. Sizes and spacings around a panel are matplotlib's defaults
(ticks 3.5 pt long, 3.5 pt from their labels, an x label 4 pt below them, the title
6 pt above the box, legends above the box's top right), so a PNG and an SVG of one
figure look alike.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from navkit.figure import TICK_PT

__all__ = ["render", "write_png", "png_bytes", "SCALE", "font_path", "load_fonts", "panel_box",
           "to_pixels"]

# How many times larger than the page a panel's lines are drawn before being shrunk to it.
SCALE = 3

# matplotlib's defaults (pt, or times the legend's font size for the legend's spacings)
_SPINE_PT = 0.8
_TICK_LEN_PT = 3.5
_TICK_PAD_PT = 3.5
_LABEL_PAD_PT = 4.0
_YLABEL_PAD_PT = 2.0            # an upright y label's box to its tick labels, as matplotlib places it
_TITLE_PT = 1.2 * TICK_PT
_TITLE_PAD_PT = 6.0
_LEGEND_PT = TICK_PT / 1.2
_LEGEND_AXES_PAD = 0.2          # between the box's top right and the legend's frame
_LEGEND_BORDER_PAD = 0.4        # inside the (invisible) frame
_LEGEND_HANDLE = 2.0            # length of a line's sample
_LEGEND_HANDLE_PAD = 0.8        # sample to its text
_LEGEND_COLUMN_GAP = 2.0        # text to the next entry's sample
_DASH = (3.7, 1.6)              # "dashed": on, off, times the line's width
_DOT = (1.0, 1.65)              # "dotted": on, off, times the line's width

# Most dashes a dashed line is drawn with (one drawing call each): a longer one, a path
# tangled over itself, is drawn solid, so its time stays bounded.
_MAX_DASHES = 3000

_WHITE = (255, 255, 255)
_BLACK = (0, 0, 0)


@functools.lru_cache(maxsize=1)
def font_path() -> str | None:
    """Path of DejaVuSans.ttf in matplotlib's package data (its spec, not its import), or
    None when matplotlib or the file is not there."""
    import importlib.util
    import os

    try:
        spec = importlib.util.find_spec("matplotlib")
    except (ImportError, ValueError):
        return None
    for folder in (spec.submodule_search_locations or []) if spec else []:
        path = os.path.join(folder, "mpl-data", "fonts", "ttf", "DejaVuSans.ttf")
        if os.path.exists(path):
            return path
    return None


@functools.lru_cache(maxsize=16)
def _font(size_px: float):
    """The page's font at `size_px` pixels (em size), with the ascent and descent (px) of
    its "lp" box: the line box matplotlib aligns text by."""
    path = font_path()
    font = ImageFont.truetype(path, size_px) if path else ImageFont.load_default(size_px)
    _, top, _, bottom = font.getbbox("lp", anchor="ls")
    return font, -top, bottom


def load_fonts(dpi: float, sizes_pt: tuple = ()) -> None:
    """Load ahead the fonts render() draws a figure of `dpi` dots per inch with: its tick,
    axis, title and legend texts and the sizes `sizes_pt` (pt: its upright labels'), each
    at the px size render() asks for, so that a process with time to spare (the log
    worker before its first batch) pays their loading before it draws."""
    for size_pt in (TICK_PT, _TITLE_PT, _LEGEND_PT, *sizes_pt):
        _font(size_pt * dpi / 72.0)


def _rgb(color: str, alpha: float = 1.0) -> tuple:
    """"#rrggbb" as (r, g, b), blended with opacity `alpha` over white."""
    c = color.lstrip("#")
    rgb = tuple(int(c[i:i + 2], 16) for i in (0, 2, 4))
    if alpha >= 1.0:
        return rgb
    return tuple(round(alpha * v + (1.0 - alpha) * 255) for v in rgb)


def panel_box(fig, panel) -> tuple:
    """(x0, y0, x1, y1): the page pixels of `panel`'s spines, left, top, right, bottom
    (its box spans columns x0..x1 and rows y0..y1, both ends included)."""
    w, h = fig.pixels
    left, bottom, width, height = panel.rect
    return (round(left * w), round((1.0 - bottom - height) * h),
            round((left + width) * w), round((1.0 - bottom) * h))


def to_pixels(fig, panel, x, y) -> tuple:
    """Data (x, y) of `panel` as page pixel coordinates (continuous: pixel i spans i..i+1;
    the spines' pixel centres are the limits), numpy arrays."""
    x0, y0, x1, y1 = panel_box(fig, panel)
    (a, b), (c, d) = panel.xlim, panel.ylim
    px = x0 + 0.5 + (np.asarray(x, dtype=float) - a) * ((x1 - x0) / (b - a))
    py = y1 + 0.5 - (np.asarray(y, dtype=float) - c) * ((y1 - y0) / (d - c))
    return px, py


def render(fig, scale: int = SCALE) -> Image.Image:
    """Finished Figure `fig` drawn as an RGB image of fig.pixels."""
    img = Image.new("RGB", fig.pixels, _WHITE)
    canvas = None
    for p in fig.panels:
        canvas = _draw_data(img, fig, p, scale, canvas)
    draw = ImageDraw.Draw(img)
    for p in fig.panels:
        _draw_frame(img, draw, fig, p)
    return img


def write_png(fig, out) -> None:
    """Finished Figure `fig` drawn (render) and written as a PNG into `out` (a path or a
    binary file), marked fig.dpi dots per inch (png_bytes)."""
    data = png_bytes(np.asarray(render(fig)), fig.dpi)
    if hasattr(out, "write"):
        out.write(data)
    else:
        with open(out, "wb") as f:
            f.write(data)


def png_bytes(pixels, dpi: float) -> bytes:
    """RGB or RGBA pixels `pixels` (a (height, width, 3 or 4) uint8 array, top row first)
    as a PNG file's bytes, marked `dpi` dots per inch. Each row but the first is stored as
    its difference from the row above (PNG filter "Up": a plot's rows are mostly alike,
    so the differences are mostly zeros, which pack small even at zlib's fastest level,
    where Pillow's encoder tries every filter on every row)."""
    import struct
    import zlib

    h, w, channels = pixels.shape
    rows = pixels.reshape(h, w * channels)
    data = np.empty((h, 1 + w * channels), dtype=np.uint8)
    data[:, 0] = 2                      # filter type of each row: Up
    data[0, 0] = 0                      # the first has no row above: None
    data[0, 1:] = rows[0]
    np.subtract(rows[1:], rows[:-1], out=data[1:, 1:])     # modulo 256, as PNG wants

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    per_m = round(dpi / 0.0254)         # pixels per metre, pHYs's unit
    color = {3: 2, 4: 6}[channels]      # PNG colour type: truecolour, with alpha
    return b"".join((b"\x89PNG\r\n\x1a\n",
                     chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, color, 0, 0, 0)),
                     chunk(b"pHYs", struct.pack(">IIB", per_m, per_m, 1)),
                     chunk(b"IDAT", zlib.compress(data, 1)),
                     chunk(b"IEND", b"")))


def _draw_data(img, fig, p, scale: int, canvas=None):
    """Panel `p`'s marks, then its lines, drawn `scale` times larger and shrunk onto `img`;
    on `canvas` (cleared) when it is the right size, as the panels of one figure usually
    are (a new image of that size costs more than clearing one). Returns the canvas."""
    x0, y0, x1, y1 = panel_box(fig, p)
    w, h = x1 - x0 + 1, y1 - y0 + 1
    if canvas is not None and canvas.size == (w * scale, h * scale):
        canvas.paste(_WHITE, (0, 0, w * scale, h * scale))
    else:
        canvas = Image.new("RGB", (w * scale, h * scale), _WHITE)
    draw = ImageDraw.Draw(canvas)
    px_per_pt = fig.dpi / 72.0 * scale
    for m in p.marks:
        xs, _ = to_pixels(fig, p, m.x, np.zeros(len(m.x)))
        _draw_marks(canvas, draw, (xs - x0) * scale, m.width * px_per_pt, m.style,
                    _rgb(m.color, m.alpha), scale)
    for ln in p.lines:
        px, py = to_pixels(fig, p, ln.x, ln.y)
        _draw_line(canvas, draw, (px - x0) * scale, (py - y0) * scale, ln.width * px_per_pt,
                   ln.style, _rgb(ln.color), scale)
    img.paste(canvas.reduce(scale) if scale > 1 else canvas, (x0, y0))
    return canvas


def _draw_marks(canvas, draw, xs, width: float, style: str, rgb: tuple, scale: int) -> None:
    """Vertical lines at canvas x `xs` (continuous px), `width` px wide, top to bottom of
    `canvas`, each on whole pixels of the page (as matplotlib snaps straight lines):
    crisp, not smeared over two columns; dotted ones with dots and gaps of whole page
    pixels too. Marks in one page column are drawn once: time bounded by the page's width."""
    w, h = canvas.size
    cols = max(1, round(width / scale))
    lefts = np.floor(np.asarray(xs, dtype=float) / scale + 0.5 - cols / 2) * scale
    lefts = _sorted_once(lefts.astype(np.int64))
    lefts = lefts[(lefts > -cols * scale) & (lefts < w)].tolist()
    if style == "dotted":
        on = max(1, round(_DOT[0] * width / scale)) * scale
        period = on + max(1, round(_DOT[1] * width / scale)) * scale
        rows = (np.arange(h) % period) < on
        dots = Image.fromarray(np.repeat(rows[:, None], cols * scale, axis=1))
        for left in lefts:
            canvas.paste(rgb, (left, 0), dots)
    else:
        for left in lefts:
            draw.rectangle((left, 0, left + cols * scale - 1, h - 1), fill=rgb)


def _sorted_once(v):
    """Integer array `v` sorted with repeats dropped (np.unique would import numpy.ma)."""
    v = np.sort(v)
    return v[np.concatenate(([True], v[1:] != v[:-1]))] if v.size else v


def _runs(px, py) -> list:
    """The stretches of points (px, py) between non-finite ones: [(xs, ys), ...]."""
    ok = np.isfinite(px) & np.isfinite(py)
    if ok.all():
        return [(px, py)]
    edges = np.flatnonzero(np.diff(np.concatenate(([0], ok.astype(np.int8), [0]))))
    return [(px[a:b], py[a:b]) for a, b in zip(edges[::2], edges[1::2])]


def _draw_line(canvas, draw, px, py, width: float, style: str, rgb: tuple, scale: int) -> None:
    """A Line's points in canvas pixels (continuous) drawn in `style`, `width` px wide."""
    if style == "points":
        _draw_dots(canvas, px, py, width / 2, rgb, scale)
        return
    w = max(1, round(width))
    for xs, ys in _runs(px, py):
        if style == "dashed" and _length(xs, ys) < _MAX_DASHES * (_DASH[0] + _DASH[1]) * width:
            xs, ys, bounds = _dashes(xs, ys, _DASH[0] * width, _DASH[1] * width)
        else:       # solid; or dashes so many that they overlap into a solid tangle anyway
            bounds = [0, xs.size]
        # Pillow's coordinates are pixel centres; one list for all pieces, sliced per piece
        flat = np.column_stack((xs - 0.5, ys - 0.5)).ravel().tolist()
        for a, b in zip(bounds[:-1], bounds[1:]):
            piece = flat[2 * a:2 * b]
            draw.line(piece if b - a > 1 else piece * 2, fill=rgb, width=w)
        if w > 2 and style != "dashed":
            _round_joins(draw, xs - 0.5, ys - 0.5, w / 2, rgb)


def _length(xs, ys) -> float:
    """Length of a polyline (its units)."""
    return float(np.hypot(np.diff(xs), np.diff(ys)).sum())


def _round_joins(draw, xs, ys, r: float, rgb: tuple) -> None:
    """Round off the corners of a wide polyline where it turns by more than 45 degrees
    between segments longer than its half width (elsewhere its segments' ends overlap)."""
    if xs.size < 3:
        return
    dx, dy = np.diff(xs), np.diff(ys)
    long = np.hypot(dx, dy) > r
    turn = (dx[:-1] * dx[1:] + dy[:-1] * dy[1:]) < 0.7071 * np.hypot(dx[:-1], dy[:-1]) * np.hypot(dx[1:], dy[1:])
    for i in np.flatnonzero(turn & (long[:-1] | long[1:])) + 1:
        draw.ellipse((xs[i] - r, ys[i] - r, xs[i] + r, ys[i] + r), fill=rgb)


def _dashes(xs, ys, on: float, off: float) -> tuple:
    """The "on" pieces of a polyline (continuous px) dashed `on`, `off` px along its length,
    starting with a dash: (xs, ys, bounds), piece i being points bounds[i]..bounds[i+1]
    (its ends cut where its dash begins and ends)."""
    seg = np.hypot(np.diff(xs), np.diff(ys))
    s = np.concatenate(([0.0], np.cumsum(seg)))
    total = float(s[-1])
    if total <= 0 or on <= 0:
        return xs, ys, [0, xs.size]
    period = on + off
    starts = np.arange(math.ceil(total / period) + 1) * period
    starts = starts[starts <= total]
    ends = np.minimum(starts + on, total)
    # each dash: its start, the vertices inside it, its end; numbered by dash
    inside = np.floor(s / period)
    vert_on = s - inside * period < on
    where = np.concatenate((starts, s[vert_on], ends))
    dash = np.concatenate((np.arange(starts.size), inside[vert_on], np.arange(ends.size)))
    order = np.lexsort((where, dash))
    where, dash = where[order], dash[order]
    bounds = np.concatenate(([0], np.flatnonzero(np.diff(dash)) + 1, [dash.size])).tolist()
    return np.interp(where, s, xs), np.interp(where, s, ys), bounds


def _draw_dots(canvas, px, py, r: float, rgb: tuple, scale: int) -> None:
    """A filled disc of radius `r` (canvas px) at each point, centred on the page pixel the
    point falls in (as matplotlib snaps markers: crisp, alike dots), stamped into a mask
    at once (one array pass per canvas pixel of a disc, not one drawing call per point)."""
    w, h = canvas.size
    ok = (px >= 0) & (px < w) & (py >= 0) & (py < h)    # in the box (NaN is not)
    # the page pixels the points fall in, each once
    cells = _sorted_once(np.floor(py[ok] / scale).astype(np.int64) * (w + 1)
                         + np.floor(px[ok] / scale).astype(np.int64))
    cy, cx = np.divmod(cells, w + 1)
    cy, cx = cy * scale + scale // 2, cx * scale + scale // 2     # the canvas pixel at its centre
    mask = np.zeros((h, w), dtype=bool)
    reach = math.ceil(r)
    centre = 0.0 if scale % 2 else 0.5          # an even scale's centre lies between pixels
    for oy in range(-reach, reach + 1):
        for ox in range(-reach, reach + 1):
            if (ox + centre) ** 2 + (oy + centre) ** 2 > r * r:
                continue
            yy, xx = cy + oy, cx + ox
            inside = (yy >= 0) & (yy < h) & (xx >= 0) & (xx < w)
            mask[yy[inside], xx[inside]] = True
    # a bilevel mask: Pillow pastes through one without blending, several times faster
    canvas.paste(rgb, (0, 0), Image.fromarray(mask))


def _aligned(at: float, size: float, how: str) -> float:
    """Where a span `size` px long starts when its start ("l", "t"), middle ("m") or end
    ("r", "b"), as `how` says, is at page px `at`."""
    return {"l": at, "t": at, "m": at - size / 2, "r": at - size, "b": at - size}[how]


def _text(draw, xy, text: str, size_pt: float, dpi: float, anchor: str, rgb=_BLACK) -> tuple:
    """Draw `text` with matplotlib's alignment: `anchor` is (horizontal l/m/r, vertical
    t/c/s/b) of its line box ("lp"'s ascent to descent; "c": the middle of ascent to the
    baseline; "s": the baseline), at page px `xy`. Returns its box (left, top, right,
    bottom)."""
    font, asc, desc = _font(size_pt * dpi / 72.0)
    width = font.getlength(text)
    x, y = xy
    left = _aligned(x, width, anchor[0])
    base = {"t": y + asc, "c": y + asc / 2, "s": y, "b": y - desc}[anchor[1]]
    draw.text((left, base), text, font=font, fill=rgb, anchor="ls")
    return (left, base - asc, left + width, base + desc)


def _upright(img, xy, text: str, size_pt: float, dpi: float, anchor: str, rgb=_BLACK) -> tuple:
    """Draw `text` turned 90 degrees counter-clockwise; `anchor` (horizontal l/m/r,
    vertical t/m/b) places the turned line box's edges or middle at page px `xy`.
    Returns its box (left, top, right, bottom)."""
    font, asc, desc = _font(size_pt * dpi / 72.0)
    length = font.getlength(text)
    tall = round(asc + desc)
    flat = Image.new("L", (max(1, math.ceil(length)), max(1, tall)), 0)
    ImageDraw.Draw(flat).text((0, asc), text, font=font, fill=255, anchor="ls")
    turned = flat.transpose(Image.Transpose.ROTATE_90)
    w, h = turned.size
    x, y = xy
    left = _aligned(x, w, anchor[0])
    top = _aligned(y, h, anchor[1])
    img.paste(rgb, (round(left), round(top)), turned)
    return (left, top, left + w, top + h)


def _draw_frame(img, draw, fig, p) -> None:
    """Panel `p`'s spines, ticks, tick labels, axis labels, title, legend and upright labels."""
    dpi = fig.dpi
    pt = dpi / 72.0
    x0, y0, x1, y1 = panel_box(fig, p)
    # spines: a black pixel with a faint one each side (0.8 pt at 110 dpi is 1.2 px)
    faint = _rgb("#000000", max(0.0, min(1.0, (_SPINE_PT * pt - 1.0) / 2)))
    draw.rectangle((x0 - 1, y0 - 1, x1 + 1, y1 + 1), outline=faint)
    draw.rectangle((x0 + 1, y0 + 1, x1 - 1, y1 - 1), outline=faint)
    draw.rectangle((x0, y0, x1, y1), outline=_BLACK)
    tick = round(_TICK_LEN_PT * pt)
    xs, _ = to_pixels(fig, p, p.xticks, np.zeros(len(p.xticks)))
    _, ys = to_pixels(fig, p, np.zeros(len(p.yticks)), p.yticks)
    below = y1 + 0.5 + (_TICK_LEN_PT + _TICK_PAD_PT) * pt
    bottom = y1 + 0.5 + _TICK_LEN_PT * pt
    for x, label in zip(xs, p.xtick_labels):
        c = math.floor(x)
        draw.line((c, y1 + 1, c, y1 + tick), fill=_BLACK)
        bottom = max(bottom, _text(draw, (x, below), label, TICK_PT, dpi, "mt")[3])
    left_of = x0 + 0.5 - (_TICK_LEN_PT + _TICK_PAD_PT) * pt
    leftmost = x0 + 0.5 - _TICK_LEN_PT * pt
    for y, label in zip(ys, p.ytick_labels):
        r = math.floor(y)
        draw.line((x0 - tick, r, x0 - 1, r), fill=_BLACK)
        leftmost = min(leftmost, _text(draw, (left_of, y), label, TICK_PT, dpi, "rc")[0])
    if p.xlabel:
        _text(draw, ((x0 + x1 + 1) / 2, bottom + _LABEL_PAD_PT * pt), p.xlabel, TICK_PT, dpi, "mt")
    if p.ylabel:
        _upright(img, (leftmost - _YLABEL_PAD_PT * pt, (y0 + y1 + 1) / 2), p.ylabel, TICK_PT,
                 dpi, "rm")
    if p.title:
        _text(draw, (x0 + 0.5, y0 + 0.5 - _TITLE_PAD_PT * pt), p.title, _TITLE_PT, dpi, "ls")
    if p.legend:
        _legend(draw, fig, p, x1 + 0.5, y0 + 0.5)
    for u in p.labels:
        x, _ = to_pixels(fig, p, [u.x], [0.0])
        at = (float(x[0]), y0 + 0.5) if u.at == "top" else (float(x[0]), y1 + 0.5)
        _upright(img, at, u.text, u.size, dpi, "rt" if u.at == "top" else "rb", _rgb(u.color))


def _legend(draw, fig, p, right: float, top: float) -> None:
    """The entries of `p`'s labelled lines in one row, its bottom right corner just above
    the box's top right corner at page px (`right`, `top`)."""
    entries = [ln for ln in p.lines if ln.label]
    if not entries:
        return
    dpi = fig.dpi
    fs = _LEGEND_PT * dpi / 72.0            # the legend's font size, px
    font, asc, desc = _font(fs)
    handle, gap, column = _LEGEND_HANDLE * fs, _LEGEND_HANDLE_PAD * fs, _LEGEND_COLUMN_GAP * fs
    inset = (_LEGEND_AXES_PAD + _LEGEND_BORDER_PAD) * fs
    base = top - inset - desc                   # the texts' baseline
    mid = base + (desc - asc) / 2               # the samples' height: the line box's middle
    x = right - inset
    for ln in reversed(entries):
        width = font.getlength(ln.label)
        x -= width
        draw.text((x, base), ln.label, font=font, fill=_BLACK, anchor="ls")
        x -= gap + handle
        rgb = _rgb(ln.color)
        lw = ln.width * dpi / 72.0
        if ln.style == "points":
            r = max(0.5, lw / 2)
            cx = x + handle / 2
            draw.ellipse((cx - r, mid - r, cx + r, mid + r), fill=rgb)
        else:
            w = max(1, round(lw))
            if ln.style == "dashed":
                xs, _, bounds = _dashes(np.array([x, x + handle]), np.zeros(2), _DASH[0] * lw, _DASH[1] * lw)
                for a, b in zip(bounds[:-1], bounds[1:]):
                    draw.line((xs[a], mid, xs[b - 1], mid), fill=rgb, width=w)
            else:
                draw.line((x, mid, x + handle, mid), fill=rgb, width=w)
        x -= column
