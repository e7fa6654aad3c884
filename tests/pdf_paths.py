"""What a PDF page draws, read back with pypdf: rectangles and stroked line
segments in page units (points), after the current transformation matrix
and the clipping rectangle; for the export tests."""

import numpy as np


def _apply(ctm, x, y):
    p = np.array([x, y, 1.0]) @ ctm
    return p[0], p[1]


def page_drawing(page):
    """(rects, segments, texts): rects (x, y, w, h) drawn with ``re`` and stroked;
    segments ((x0, y0), (x1, y1), clipped) of every stroked path, cut to the clip
    rectangle in force (``clipped``: drawn under a clip, as the tiles draw the
    pattern; the page's own marks are not); texts: every string shown (Tj / TJ)."""
    from pypdf.generic import ContentStream
    from shapely.geometry import LineString, box

    ops = ContentStream(page.get_contents(), page.pdf).operations
    ctm, clip, stack = np.eye(3), None, []
    rects, segments, texts = [], [], []
    path, current, start, path_rects = [], None, None, []
    pending_clip = False
    for operands, op in ops:
        if op == b"q":
            stack.append((ctm.copy(), clip))
        elif op == b"Q":
            ctm, clip = stack.pop()
        elif op == b"cm":
            a, b, c, d, e, f = (float(x) for x in operands)
            ctm = np.array([[a, b, 0], [c, d, 0], [e, f, 1]]) @ ctm
        elif op == b"m":
            current = start = _apply(ctm, *map(float, operands))
        elif op == b"l":
            p = _apply(ctm, *map(float, operands))
            path.append((current, p))
            current = p
        elif op == b"c":  # a Bezier: its control polygon is a fair stand-in
            pts = [_apply(ctm, float(operands[i]), float(operands[i + 1])) for i in (0, 2, 4)]
            for p in pts:
                path.append((current, p))
                current = p
        elif op == b"h":
            if current is not None and start is not None:
                path.append((current, start))
                current = start
        elif op == b"re":
            x, y, w, h = (float(v) for v in operands)
            corners = [_apply(ctm, x, y), _apply(ctm, x + w, y), _apply(ctm, x + w, y + h), _apply(ctm, x, y + h)]
            path_rects.append(corners)
            path += list(zip(corners, corners[1:] + corners[:1]))
        elif op in (b"W", b"W*"):
            pending_clip = True
        elif op in (b"S", b"s", b"B", b"B*", b"b", b"b*", b"f", b"F", b"f*", b"n"):
            stroked = op in (b"S", b"s", b"B", b"B*", b"b", b"b*")
            if pending_clip and path_rects:
                xs = [p[0] for p in path_rects[-1]]
                ys = [p[1] for p in path_rects[-1]]
                clip = box(min(xs), min(ys), max(xs), max(ys))
            if stroked:
                for corners in path_rects:
                    xs = [p[0] for p in corners]
                    ys = [p[1] for p in corners]
                    rects.append((min(xs), min(ys), max(xs) - min(xs), max(ys) - min(ys)))
                for a, b in path:
                    if clip is None:
                        segments.append((a, b, False))
                    else:
                        g = LineString([a, b]).intersection(clip)
                        if not g.is_empty and g.length > 0:
                            cs = list(g.coords)
                            segments.append((cs[0], cs[-1], True))
            path, current, start, path_rects, pending_clip = [], None, None, [], False
        elif op in (b"Tj", b"'", b'"'):
            texts.append(str(operands[-1]))
        elif op == b"TJ":
            texts.append("".join(str(x) for x in operands[0] if isinstance(x, str)))
    return rects, segments, texts


def find_squares(rects, sides_pt, tol=0.01):
    """The rectangles that are squares of one of the sides (points)."""
    return [r for r in rects if any(abs(r[2] - s) < tol and abs(r[3] - s) < tol for s in sides_pt)]


def lines_over(square, segments, tol=0.05):
    """The segments that cross or touch the square's area, other than its own edges."""
    from shapely.geometry import LineString, box

    x, y, w, h = square
    area = box(x, y, x + w, y + h)
    edges = area.boundary
    out = []
    for a, b, *_ in segments:
        seg = LineString([a, b])
        if seg.length == 0 or not seg.intersects(area):
            continue
        if seg.difference(edges.buffer(tol)).is_empty:  # one of the square's own sides
            continue
        out.append((a, b))
    return out
