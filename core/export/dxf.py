"""DXF for cutting rooms and CAD, written with ezdxf, in two variants.

Both use the AAMA / ASTM D6673 numbered layers (the names are the numbers):
1 cut line (piece boundary), 14 sew line, 8 internal lines (dart legs), 4
notches, 7 grain line, 11 internal cut-outs, 13 drill holes, 15 annotation;
millimetres. Each piece is one block holding the piece in the result file's
own frame (``nodes.xy`` x mm per unit), inserted once at its place on the
sheet: the INSERT's insertion point is the piece's offset, so sheet = result
xy x mm per unit + insertion point, and a pattern overlaid with the JSON, OBJ
or VTP lines up.

``astm`` (the default) follows ASTM D6673-10 for pattern-making and cutting-room
software (Gerber AccuMark, Lectra Modaris, Optitex, ...): DXF R12 (AC1009), 7-bit
ASCII, written by ezdxf's ``gerber_D6673`` add-on so the BLOCKS section holds
the pieces' blocks and nothing else (no ``$MODEL_SPACE`` / ``$PAPER_SPACE``
layout blocks, which AccuMark takes for pieces: ezdxf issue 786) and there is
no TABLES section; the header holds only ``$ACADVER``, ``$EXTMIN`` and
``$EXTMAX``. In each block the piece system text is TEXT on layer 1
(``Piece Name:``, ``Size:``, ``Quantity:``, ``Material:``, ``Category:``) and
the rest of the label on layer 15; the style system text (``Style Name:``,
``Creation Date:``, ``Author:``, ``Sample Size:``, ``Grading Rule Table:``,
``Units: METRIC``) is TEXT on layer 1 in the model space, once, below the pieces
and their labels. In both variants ``$EXTMIN`` / ``$EXTMAX`` bound everything drawn:
the pieces, their labels (which stand out of a piece too small for them) and the
style text, its glyphs measured by ezdxf.

``layered`` is plain AutoCAD R2000 (AC1015) for CAD and laser / knife cutters
that read ordinary DXF (LibreCAD, AutoCAD, QCAD, GDAL, ...): a layer table with
colours and descriptions, ``$INSUNITS`` = 4 (mm), ``$MEASUREMENT`` = 1, extents,
the same blocks and the whole label on layer 15.
"""

from __future__ import annotations

import datetime as _dt
import io
import re

import numpy as np

from flatweave.version import __version__
from flatweave.export.sheet import LINE_PITCH, Sheet

__all__ = ["LAYERS", "VARIANTS", "dxf_bytes", "style_text"]

# layer name -> (description, ACI colour)
LAYERS = {
    "1": ("cut line (outline with seam allowance)", 7),
    "14": ("sew line", 3),
    "8": ("internal lines (drawn, not cut)", 5),
    "4": ("notches", 1),
    "7": ("grain line", 6),
    "11": ("internal cut-outs", 4),
    "13": ("drill holes", 2),
    "15": ("annotation", 8),
}

VARIANTS = {
    "astm": "ASTM D6673 / AAMA, DXF R12: pattern CAD and cutting rooms (Gerber AccuMark, Lectra, Optitex)",
    "layered": "AutoCAD R2000 with AAMA layers and $INSUNITS: CAD, GDAL, laser and knife cutters",
}


def _block_name(name: str, k: int, taken: set) -> str:
    base = re.sub(r"[^A-Za-z0-9_-]+", "_", name).strip("_") or f"PIECE_{k + 1}"
    out, n = base, 2
    while out.upper() in taken:
        out, n = f"{base}_{n}", n + 1
    taken.add(out.upper())
    return out


def style_text(sheet: Sheet) -> tuple:
    """ASTM D6673's style system text: (key, value) pairs, once per file."""
    return (("Style Name", sheet.name), ("Creation Date", _dt.date.today().strftime("%m-%d-%Y")),
            ("Author", f"flatweave {__version__}"), ("Sample Size", "base"),
            ("Grading Rule Table", "none"), ("Units", "METRIC"))


def _extents(msp) -> tuple[np.ndarray, np.ndarray]:
    """(lower-left, upper-right) of everything in the model space, the blocks' contents
    and every TEXT's glyphs included (ezdxf measures text with the font its style names)."""
    from ezdxf import bbox

    box = bbox.extents(msp)
    return np.array(box.extmin, dtype=float)[:2], np.array(box.extmax, dtype=float)[:2]


def dxf_bytes(sheet: Sheet, variant: str = "astm", inserts=None, roll=None) -> bytes:
    """The sheet as a DXF file (bytes, in the file's own encoding). ``$EXTMIN`` /
    ``$EXTMAX`` are the drawing's extent: the pieces, their labels and the style text.

    A marker (:mod:`flatweave.export.marker`): ``inserts``, per piece of the sheet, the
    (x, y, rotation in degrees) of each copy placed (its block inserted there, turned about
    its frame's origin, in place of once at its offset), and ``roll`` (length, width) mm, the
    roll's edges and ends drawn as lines on the annotation layer 15."""
    import ezdxf

    if variant not in VARIANTS:
        raise ValueError(f"unknown DXF variant {variant!r}: use one of {', '.join(VARIANTS)}")
    astm = variant == "astm"
    if astm:  # (ezdxf.new would set $INSUNITS, which R12 has not, and log that it is not written)
        from ezdxf.document import Drawing

        doc = Drawing.new("AC1009")
    else:
        doc = ezdxf.new("R2000", setup=False)
        from ezdxf import units

        doc.units = units.MM  # $INSUNITS = 4
        doc.header["$MEASUREMENT"] = 1  # metric
        doc.header["$LUNITS"] = 2  # decimal
        for name, (desc, colour) in LAYERS.items():
            doc.layers.add(name, color=colour).description = desc
    msp = doc.modelspace()

    def attribs(layer):
        # without a layer table (astm), give each entity its layer's colour
        return {"layer": layer, "color": LAYERS[layer][1]} if astm else {"layer": layer}

    taken: set = set()
    for k, piece in enumerate(sheet.pieces):
        bname = _block_name(piece.name, k, taken)
        blk = doc.blocks.new(name=bname, base_point=(0.0, 0.0), dxfattribs={"layer": "1" if astm else "0"})
        off = np.asarray(piece.offset, dtype=float)

        def poly(points, layer, closed):
            pts = [tuple(map(float, p - off)) for p in points]
            if astm:
                blk.add_polyline2d(pts, close=closed, dxfattribs=attribs(layer))
            else:
                blk.add_lwpolyline(pts, close=closed, dxfattribs=attribs(layer))

        def line(a, b, layer):
            blk.add_line(tuple(map(float, a - off)), tuple(map(float, b - off)), dxfattribs=attribs(layer))

        poly(piece.outer, "1", True)  # the line to cut: the cut line, or the sew line without an allowance
        poly(piece.sew, "14", True)
        for h in piece.holes:
            poly(h, "14", True)
        for h in (piece.hole_cuts if piece.cut is not None else piece.holes):
            poly(h, "11", True)
        for leg in piece.internal:
            poly(leg, "8", False)
        for notch in piece.notches:
            line(notch[0], notch[1], "4")
        for d in piece.drills:
            blk.add_point(tuple(map(float, d - off)), dxfattribs=attribs("13"))
        line(piece.grain[0], piece.grain[1], "7")
        for head in piece.grain_heads:
            poly(head, "7", False)
        n_system = len(piece.system_text) if astm else 0
        x, y = np.asarray(piece.label_at, dtype=float) - off
        for i, text in enumerate(piece.label):
            t = blk.add_text(text, height=piece.label_height, dxfattribs=attribs("1" if i < n_system else "15"))
            t.set_placement((float(x), float(y - LINE_PITCH * piece.label_height * i)))
        places = [(float(off[0]), float(off[1]), 0.0)] if inserts is None else inserts[k]
        for x0, y0, rot in places:
            ref = {"layer": "1" if astm else "0", **({"rotation": float(rot)} if rot else {})}
            msp.add_blockref(bname, (float(x0), float(y0)), dxfattribs=ref)
    if roll is not None:
        length, width = roll
        for a, b in (((0, 0), (length, 0)), ((0, width), (length, width)), ((0, 0), (0, width)),
                     ((length, 0), (length, width))):
            msp.add_line(tuple(map(float, a)), tuple(map(float, b)), dxfattribs=attribs("15"))
    lo, hi = _extents(msp)  # the pieces with their labels, which may stand out of a small piece
    if astm:  # the style system text, once, below everything else
        lines = [f"{k}: {v}" for k, v in style_text(sheet)]
        h = float(np.clip(0.01 * (hi - lo).max(), 3.0, 8.0))
        top = lo[1] - 3.0 * h
        for i, text in enumerate(lines):
            t = msp.add_text(text, height=h, dxfattribs=attribs("1"))
            t.set_placement((float(lo[0]), float(top - LINE_PITCH * h * i)))
        lo, hi = _extents(msp)
    extmin, extmax = (float(lo[0]), float(lo[1]), 0.0), (float(hi[0]), float(hi[1]), 0.0)
    stream = io.StringIO()
    if astm:
        from ezdxf.addons import gerber_D6673

        gerber_D6673.export_stream(doc, stream)
        text = stream.getvalue()
        empty = "  0\nSECTION\n  2\nHEADER\n  0\nENDSEC\n"
        assert text.startswith(empty), "ezdxf's gerber_D6673 add-on writes an empty HEADER first"
        header = ["  0", "SECTION", "  2", "HEADER", "  9", "$ACADVER", "  1", "AC1009"]
        for var, p in (("$EXTMIN", extmin), ("$EXTMAX", extmax)):
            header += ["  9", var, " 10", f"{p[0]:.6f}", " 20", f"{p[1]:.6f}", " 30", "0.0"]
        text = "\n".join(header + ["  0", "ENDSEC"]) + "\n" + text[len(empty):]
        return text.encode("ascii", errors="replace")
    # ezdxf writes the model space's extents as $EXTMIN / $EXTMAX, unless they are (0, 0, 0)
    msp.reset_extents(extmin, extmax)
    doc.header["$EXTMIN"], doc.header["$EXTMAX"] = extmin, extmax
    doc.write(stream)
    return stream.getvalue().encode(doc.output_encoding, errors="replace")
