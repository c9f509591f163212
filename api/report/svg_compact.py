"""Make matplotlib's SVG text small without changing what it draws.

Matplotlib writes every coordinate with six decimals on a line of its own, every style in full
on every element, two or three empty ``<g>`` around each artist and an 11-character hash as
every id. A report of 25 plots paid about 24 kB per plot for that. :func:`compact` rewrites the
text of one SVG:

- coordinates rounded to :data:`DECIMALS` decimals of a point (0.1 pt, 0.035 mm on paper; a
  marker shape, defined once, keeps :data:`MARKER_DECIMALS`), path data without the spaces and
  line breaks between commands;
- each style that several elements share written once, as a class of the SVG's own
  ``<style>`` (the class names start with the SVG's id prefix, so several SVGs in one page
  never share one);
- ``<g>`` elements without attributes unwrapped (they group nothing a reader can see);
- matplotlib's hashed ids (markers ``m…``, clip paths ``p…``) renamed ``m0``, ``c0`` …;
- no line breaks between elements.

Text (tick labels, legends, titles) is left as written; only attribute values change.
"""

from __future__ import annotations

import hashlib
import re
from collections import Counter

#: Decimals kept of a coordinate [pt].
DECIMALS = 1
#: Decimals kept of a marker's shape (a few points across, drawn once in ``<defs>``) [pt].
MARKER_DECIMALS = 2

_NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?")
_PATH = re.compile(r'<path( id="[^"]*")? d="([^"]*)"')
_COORDINATE = re.compile(r'\b(x|y|x1|x2|y1|y2|width|height|transform)="([^"]*)"')
_STYLE = re.compile(r' style="([^"]*)"')
_USE_ONE = r'<use xlink:href="#([^"]+)" x="([^"]+)" y="([^"]+)" style="([^"]*)"/>'
_USE = re.compile(_USE_ONE)
_USE_RUN = re.compile(f"(?:{_USE_ONE.replace('(', '(?:').replace('(?:?', '(?')})+")
_MARKER_DEF = re.compile(r'<path id="([^"]+)" d="([^"]*)"(?: style="([^"]*)")?/>')
#: Style properties a marker may have to be drawn as round dots.
_PLAIN = {"fill", "stroke", "stroke-width", "stroke-linejoin", "stroke-linecap"}
_GROUP = re.compile(r"<g(?:\s[^>]*)?/?>|</g>")


def _rounded(text: str, decimals: int) -> str:
    def one(match: re.Match[str]) -> str:
        value = round(float(match.group(0)), decimals)
        out = f"{value:.{decimals}f}".rstrip("0").rstrip(".")
        return "0" if out in ("-0", "") else out

    return _NUMBER.sub(one, text)


def _path_data(data: str, decimals: int) -> str:
    """``M 0 410.400000 L 540 410.4 L 540 0 z`` (with line breaks) as ``M0 410.4h540v-410.4z``.

    Lines are relative to the pen (``l dx dy``, ``h dx``, ``v dy``: shorter numbers); a line to
    the point the pen is at (after another line) is dropped, lines on along one horizontal or
    vertical are one command.
    """
    tokens = _rounded(" ".join(data.split()), decimals).split(" ")
    out: list[str] = []
    pen, before, last = ("", ""), ("", ""), ""
    i = 0
    while i < len(tokens):
        command = tokens[i]
        size = {"M": 2, "L": 2, "C": 6, "Q": 4}.get(command, 0)
        numbers = tokens[i + 1 : i + 1 + size]
        i += size + 1
        if command == "L" and last:
            x, y = numbers
            if (x, y) == pen and last != "M":
                continue
            axis = "V" if x == pen[0] else "H" if y == pen[1] else ""
            coordinate = y if axis == "V" else x
            index = 1 if axis == "V" else 0
            if axis and last == axis and _same_way(before[index], pen[index], coordinate):
                # on along the same line: one command, from where the line began
                out[-1] = axis.lower() + _delta(coordinate, before[index], decimals)
            else:
                before = pen
                if axis:
                    out.append(axis.lower() + _delta(coordinate, pen[index], decimals))
                else:
                    dx, dy = _delta(x, pen[0], decimals), _delta(y, pen[1], decimals)
                    out.append(f"l{dx} {dy}")
            last = axis or "L"
        else:
            before = pen
            out.append(command + " ".join(numbers))
            last = command
        if size:
            pen = (numbers[-2], numbers[-1])
    return "".join(out)


def _delta(to: str, start: str, decimals: int) -> str:
    """``to - start`` as written (both already rounded to ``decimals``: exact, no drift)."""
    return _rounded(f"{float(to) - float(start):.{decimals}f}", decimals)


def _same_way(start: str, middle: str, end: str) -> bool:
    """Whether ``middle`` lies between ``start`` and ``end`` (a line goes on the same way)."""
    a, b, c = float(start), float(middle), float(end)
    return (a <= b <= c) or (a >= b >= c)


def _paths(svg: str) -> str:
    def one(match: re.Match[str]) -> str:
        ident, data = match.group(1) or "", match.group(2)
        # a marker (a few points across, drawn at every data point) keeps more decimals
        decimals = MARKER_DECIMALS if ident and len(data) < 1000 else DECIMALS
        return f'<path{ident} d="{_path_data(data, decimals)}"'

    return _PATH.sub(one, svg)


def _coordinates(svg: str) -> str:
    def one(match: re.Match[str]) -> str:
        name, value = match.groups()
        if value.endswith("pt"):  # the figure's size: as matplotlib wrote it
            return match.group(0)
        return f'{name}="{_rounded(value, DECIMALS)}"'

    return _COORDINATE.sub(one, svg)


def _style_map(style: str) -> dict[str, str]:
    pairs = (item.split(":", 1) for item in style.split(";") if ":" in item)
    return {k.strip(): v.strip() for k, v in pairs}


def _style_text(style: dict[str, str]) -> str:
    return ";".join(f"{k}:{v}" for k, v in style.items())


def _classes(svg: str) -> str:
    """Each style used more than once becomes a class defined in the SVG's ``<style>``.

    A class is named after a hash of its style: the same style has the same class in every
    SVG of a page, and two different styles never share a name.
    """
    tidy = {s: _style_text(_style_map(s)) for s in _STYLE.findall(svg)}
    counts = Counter(tidy[s] for s in _STYLE.findall(svg))
    shared = {
        style: "s" + hashlib.sha256(style.encode()).hexdigest()[:6]
        for style, n in counts.most_common()
        if n > 1
    }

    def one(match: re.Match[str]) -> str:
        style = tidy[match.group(1)]
        return f' class="{shared[style]}"' if style in shared else f' style="{style}"'

    svg = _STYLE.sub(one, svg)
    rules = "".join(f".{name}{{{style}}}" for style, name in shared.items())
    if "</style>" in svg:
        return svg.replace("</style>", f"{rules}</style>", 1)
    return svg.replace(">", f"><defs><style>{rules}</style></defs>", 1) if rules else svg


def _marker_shapes(svg: str) -> dict[str, tuple[str, dict[str, str]]]:
    """Marker definitions by id: path data and the style they set."""
    return {
        m.group(1): (m.group(2), _style_map(m.group(3) or "")) for m in _MARKER_DEF.finditer(svg)
    }


def _dot_width(data: str) -> float | None:
    """The diameter of a circle marker (matplotlib's, centred on 0), None for another shape."""
    if not data.startswith("M0 ") or set(re.sub(r"[-\d. ]", "", data)) != {"M", "C", "z"}:
        return None
    numbers = [abs(float(n)) for n in _NUMBER.findall(data)]
    radius = float(data[3:].split("C")[0])
    return 2 * radius if max(numbers) <= radius + 1e-9 else None


def _relative(data: str) -> tuple[float, float, str] | None:
    """A marker's first point and its lines (``M l h v z`` only) relative to that point."""
    parts = re.findall(r"([A-Za-z])([^A-Za-z]*)", data)
    if not parts or parts[0][0] != "M" or any(c not in "Mlhvz" for c, _ in parts[1:]):
        return None
    x0, y0 = (float(v) for v in parts[0][1].split())
    (x, y), start, out = (x0, y0), (x0, y0), []
    for command, args in parts[1:]:
        values = [float(v) for v in args.split()]
        if command == "M":  # a new stroke: relative to the pen too
            out.append(f"m{_n(values[0] - x)} {_n(values[1] - y)}")
            (x, y) = start = (values[0], values[1])
            continue
        out.append(command + args)
        if command == "l":
            x, y = x + values[0], y + values[1]
        elif command == "h":
            x += values[0]
        elif command == "v":
            y += values[0]
        else:
            x, y = start
    return x0, y0, "".join(out)


def _n(value: float) -> str:
    return _rounded(f"{value:.{MARKER_DECIMALS}f}", MARKER_DECIMALS)


def _marker_runs(svg: str) -> str:
    """Consecutive ``<use>`` of one marker and style as one ``<path>``.

    A ``use`` per point costs 60 bytes, a point of the path 12 to 30.
    A filled circle whose edge has its fill's colour is a zero-length line with round caps
    as wide as the circle and its edge; a marker of straight lines is repeated, relative to
    each point. Other markers stay ``<use>``.
    """
    shapes = _marker_shapes(svg)

    def one(match: re.Match[str]) -> str:
        uses = _USE.findall(match.group(0))
        ident, style = uses[0][0], uses[0][3]
        if len(uses) < 2 or any((u[0], u[3]) != (ident, style) for u in uses):
            return match.group(0)
        data, own = shapes.get(ident, ("", {}))
        merged = {**_style_map(style), **own}
        points = [(float(u[1]), float(u[2])) for u in uses]
        width = _dot_width(data)
        fill = merged.get("fill", "#000000")
        if width is not None and fill == merged.get("stroke", fill) and set(merged) <= _PLAIN:
            edge = float(merged.get("stroke-width", "1"))
            dot = {"fill": "none", "stroke": fill, "stroke-width": _n(width + edge)}
            path = "".join(f"M{_n(x)} {_n(y)}h0" for x, y in points)
            return f'<path d="{path}" style="{_style_text({**dot, "stroke-linecap": "round"})}"/>'
        relative = _relative(data)
        if relative is None:
            return match.group(0)
        x0, y0, shape = relative
        path = "".join(f"M{_n(x + x0)} {_n(y + y0)}{shape}" for x, y in points)
        return f'<path d="{path}" style="{_style_text(merged)}"/>'

    return _USE_RUN.sub(one, svg)


def _unwrap_groups(svg: str) -> str:
    """Drop every ``<g>`` without attributes and its ``</g>``, keeping what it holds."""
    out: list[str] = []
    kept: list[bool] = []
    start = 0
    for match in _GROUP.finditer(svg):
        token = match.group(0)
        out.append(svg[start : match.start()])
        start = match.end()
        if token == "</g>":
            if kept.pop():
                out.append(token)
        elif token == "<g>":
            kept.append(False)
        else:
            out.append(token)
            if not token.endswith("/>"):
                kept.append(True)
    out.append(svg[start:])
    return "".join(out)


def _short_ids(svg: str) -> str:
    """Matplotlib's hashed ids (``me60b8a35b8``, ``pb8528217f5``) as ``m0``, ``c0`` ..."""
    names: dict[str, str] = {}

    def one(match: re.Match[str]) -> str:
        if match.group(0) not in names:
            kind = "m" if match.group(0)[0] == "m" else "c"
            names[match.group(0)] = f"{kind}{sum(n[0] == kind for n in names.values())}"
        return names[match.group(0)]

    return re.sub(r'(?<=id=")[mp][0-9a-f]{10}(?=")|(?<=#)[mp][0-9a-f]{10}\b', one, svg)


def compact(svg: str) -> str:
    """The same drawing as ``svg`` (matplotlib's SVG output, ids not yet prefixed), smaller.

    Parameters
    ----------
    svg : str
        One ``<svg>`` element as matplotlib writes it.
    """
    svg = _short_ids(svg)
    svg = _paths(svg)
    svg = _coordinates(svg)
    svg = re.sub(r' transform="rotate\(-?0 [^")]*\)"', "", svg)
    svg = _unwrap_groups(svg)
    svg = re.sub(r">\s+<", "><", svg).strip()
    svg = _marker_runs(svg)
    return _classes(svg)
