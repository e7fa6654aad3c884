"""DXF in the AAMA / ASTM D6673 style, written with ezdxf.

Numbered layers (the names are the numbers, as cutting-room software expects):
1 cut line, 14 sew line, 8 internal lines (dart legs), 4 notches, 7 grain
line, 11 internal cut-outs, 13 drill holes, 15 annotation. One block per
piece, inserted at the origin of the sheet (the pieces are already laid out
side by side). Release R2000 (AC1015), millimetres stated in the header
($INSUNITS = 4, $MEASUREMENT = 1).
"""

from __future__ import annotations

import io
import re


from core.export.sheet import Sheet

__all__ = ["LAYERS", "dxf_bytes"]

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


def _block_name(name: str, k: int, taken: set) -> str:
    base = re.sub(r"[^A-Za-z0-9_-]+", "_", name).strip("_") or f"PIECE_{k + 1}"
    out, n = base, 2
    while out.upper() in taken:
        out, n = f"{base}_{n}", n + 1
    taken.add(out.upper())
    return out


def dxf_bytes(sheet: Sheet) -> bytes:
    """The sheet as an R2000 DXF file (bytes, in the file's own encoding)."""
    import ezdxf
    from ezdxf import units

    doc = ezdxf.new("R2000", setup=False)
    doc.units = units.MM  # $INSUNITS = 4
    doc.header["$MEASUREMENT"] = 1  # metric
    doc.header["$LUNITS"] = 2  # decimal
    for name, (desc, colour) in LAYERS.items():
        doc.layers.add(name, color=colour).description = desc
    msp = doc.modelspace()
    taken: set = set()
    for k, piece in enumerate(sheet.pieces):
        bname = _block_name(piece.name, k, taken)
        blk = doc.blocks.new(name=bname)

        def poly(points, layer, closed):
            blk.add_lwpolyline([tuple(map(float, p)) for p in points], close=closed,
                               dxfattribs={"layer": layer})

        if piece.cut is not None:
            poly(piece.cut, "1", True)
        else:  # no allowance: the sew line is also the line to cut
            poly(piece.sew, "1", True)
        poly(piece.sew, "14", True)
        for h in piece.holes:
            poly(h, "14", True)
        for h in (piece.hole_cuts if piece.cut is not None else piece.holes):
            poly(h, "11", True)
        for leg in piece.internal:
            poly(leg, "8", False)
        for notch in piece.notches:
            blk.add_line(tuple(notch[0]), tuple(notch[1]), dxfattribs={"layer": "4"})
        for d in piece.drills:
            blk.add_point(tuple(map(float, d)), dxfattribs={"layer": "13"})
        blk.add_line(tuple(piece.grain[0]), tuple(piece.grain[1]), dxfattribs={"layer": "7"})
        for head in piece.grain_heads:
            poly(head, "7", False)
        x, y = map(float, piece.label_at)
        for i, line in enumerate(piece.label):
            t = blk.add_text(line, height=piece.label_height, dxfattribs={"layer": "15"})
            t.set_placement((x, y - 1.6 * piece.label_height * i))
        msp.add_blockref(bname, (0.0, 0.0), dxfattribs={"layer": "0"})
    w, h = sheet.size
    doc.header["$EXTMIN"] = (0.0, 0.0, 0.0)
    doc.header["$EXTMAX"] = (float(w), float(h), 0.0)
    stream = io.StringIO()
    doc.write(stream)
    return stream.getvalue().encode(doc.output_encoding, errors="replace")


