"""`isoscope measure`: each surface's area, enclosed volume, pieces and bounding box, as a table or JSON.

Measured on the mesh export would write (the same extraction, in world coordinates where the file
has them), so the numbers agree with what a mesh tool says of the exported file.  Lengths are taken as
millimetres, as a scan's world frame gives them (a file without one: its spacing's units), unless the file states
another unit (an OME-Zarr image's axes in micrometres, a NIfTI in microns): then they are converted to millimetres
(`unit` in each row names the file's), while the exported mesh keeps the file's own units.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys

from ..core.units import TAKEN_AS_MM, mm_per_unit
from .arguments import VOLUME_HELP, OneLineParser, _add_iso, add_force_labels, add_topology, max_labels
from .common import LABEL_MESH_FLAGS, check_label_options, checked_levels, progress
from .volume_options import add_volume_arguments, each_time_point

ML_PER_MM3 = 1e-3


def measure_parser() -> argparse.ArgumentParser:
    """The parser of ``isoscope measure``."""
    parser = OneLineParser(prog="isoscope measure",
                           description="Measure each surface: area (mm^2), enclosed volume (mL), connected "
                                       "pieces and bounding box, in the scan's world coordinates.")
    parser.add_argument("volume", metavar="VOLUME", help=VOLUME_HELP)
    _add_iso(parser, "; repeat for several surfaces (up to 4)")
    parser.add_argument("--labels", action="store_true", help="measure each non-zero label's surface instead")
    add_force_labels(parser)
    parser.add_argument("--max-labels", type=max_labels, metavar="N",
                        help="with --labels: refuse a volume of more than N labels (default 255)")
    parser.add_argument("--label-names", metavar="FILE",
                        help="with --labels: each label's name (key `name`) from an ITK-SNAP label description or a "
                             "3D Slicer colour table (default: VOLUME's stem + .ctbl, .txt or _label_description.txt)")
    parser.add_argument("--space", choices=("world", "voxel"), default="world",
                        help="world (default): the file's world coordinates where it has them; voxel: index x "
                             "spacing")
    parser.add_argument("--closed", action="store_true",
                        help="cap each surface where it leaves the volume (as export --closed), so its volume counts")
    add_topology(parser)
    parser.add_argument("--json", action="store_true",
                        help="print only JSON on stdout: a list with one object per surface")
    add_volume_arguments(parser)
    return parser


def run_measure(args) -> int:
    """``isoscope measure``: each surface's measures (each level's, or each label's with --labels; per time point with
    --time all or A:B), as a table or as JSON; the exit status."""
    if args.labels:
        check_label_options(args, "--iso", "--closed", *LABEL_MESH_FLAGS)   # a label's surface is closed already
    else:
        check_label_options(args, "--max-labels", "--label-names", "--force-labels")
    records, told = [], set()
    for time, volume in each_time_point(args.volume, args, progress):   # --time all or A:B: rows per time point
        for note in volume.notes:   # units the file states but that cannot be used: its numbers are taken as mm
            if TAKEN_AS_MM in note and note not in told:
                told.add(note)
                print(f"note: {note}", file=sys.stderr)
        stamp = {} if time is None else {"time": time}
        records += [dict(stamp, **record) for record in _records(volume, args)]
    if args.json:
        print(json.dumps(records, indent=1, allow_nan=False))
        return 0
    converted = sorted({r["unit"] for r in records if r["unit"] is not None and mm_per_unit(r["unit"]) != 1.0})
    if converted:   # said once: the numbers below are no longer in the file's own units
        print(f"note: {os.path.basename(args.volume.rstrip('/'))}'s lengths are in {' and '.join(converted)}: "
              "converted to mm, mm^2 and mL")
    for record in records:
        what = f"label {record['label']}" if "label" in record else f"level {record['level']:g}"
        what = what if "time" not in record else f"time {record['time']}, {what}"
        what += f" ({record['name']})" if record.get("name") else ""
        if not record["components"]:
            print(f"{what}: no surface (the level cuts nothing)")
            continue
        size = " x ".join(f"{hi - lo:.4g}" for lo, hi in zip(record["bbox_min"], record["bbox_max"]))
        note = (f"; open at {record['open_edges']:,} edges (it leaves the volume, so its volume is not the "
                "object's: --closed caps it)" if record["open_edges"] else "")
        # A hollow's inner walls are pieces too, enclosing less than nothing: "219 pieces, largest 1701.5 mL"
        # of 1700.8 mL read wrong until the cavities were named.
        cavities = (f"; {record['cavities']:,} of them {'cavities' if record['cavities'] != 1 else 'a cavity'} taking "
                    f"{record['cavities_ml']:.6g} mL away" if record["cavities"] else "")
        # Topology: the Euler characteristic, and for a closed surface its handles (genus, summed over pieces).
        shape = (f", Euler characteristic {record['euler']}" +
                 (f", genus {record['genus']}" if record["genus"] is not None else ""))
        print(f"{what}: area {record['area_mm2']:.6g} mm^2, volume {record['volume_ml']:.6g} mL, "
              f"{record['components']:,} piece{'s' * (record['components'] != 1)} (largest "
              f"{record['largest_component_ml']:.6g} mL{cavities}){shape}, box {size} mm{note}")
    return 0


def _records(volume, args) -> list[dict]:
    """measure's rows for one volume (one time point): a row per --iso level, or per label with --labels."""
    from ..cpu.measure import in_millimetres, measure_surface
    from ..io.export import in_volume_space
    world = args.space == "world"
    rows = []
    if args.labels:
        from ..labels import DEFAULT_MAX_LABELS, label_surfaces, labels_of, refuse_a_scan
        refuse_a_scan(volume, args.force_labels)
        limit = DEFAULT_MAX_LABELS if args.max_labels is None else args.max_labels
        from ..volumes.label_names import label_names_for
        names = label_names_for(volume.source, args.label_names)   # a bad file: its line, before any work
        surfaces = label_surfaces(labels_of(volume), spacing=volume.spacing, max_labels=limit)
        for label, mesh in surfaces.items():
            verts, faces, _, _ = in_volume_space(volume, *mesh, world=world)
            name = names[label].name if label in names else None
            rows.append(({"label": int(label), "name": name}, measure_surface(verts, faces)))
    else:
        from ..validation import as_level
        from .export import _extract_for_export
        # the plain, whole-volume extraction of export (--closed as given)
        args_for_export = argparse.Namespace(chunk=None, workers=None, scheduler=None, tetrahedra=False, smooth=0,
                                             sharp=None, closed=args.closed, topology=args.topology)
        for iso in checked_levels(volume, args.iso):
            verts, faces, normals, _ = _extract_for_export(volume, iso, args_for_export)
            verts, faces, _, _ = in_volume_space(volume, verts, faces, normals, world=world)
            rows.append(({"level": as_level(iso, volume.value_range)}, measure_surface(verts, faces)))
    rows = [_object_side(key, in_millimetres(m, mm_per_unit(volume.length_unit)), volume, args.labels)
            for key, m in rows]   # the file's lengths (micrometres, ...) in millimetres
    return [dict(key, unit=volume.length_unit, area_mm2=m.area, volume_ml=m.volume * ML_PER_MM3,
                 components=m.components, largest_component_ml=m.largest_component_volume * ML_PER_MM3,
                 bbox_min=_finite_or_none(m.bbox_min), bbox_max=_finite_or_none(m.bbox_max),
                 open_edges=m.open_edges, cavities=m.cavities, cavities_ml=-m.cavity_volume * ML_PER_MM3,
                 euler=m.euler, genus=m.genus)
            for key, m in rows]


def _object_side(key: dict, m, volume, labels: bool):
    """(key with `inside`: the side of the level the object is on, the measures of that object).  A closed
    surface enclosing less than nothing faces into what it encloses: the object is on the other side of the
    level from the volume's (a file is taken as a density, object above; a signed distance's is below), so
    its volume is given positive, with a note line saying which side it is on and the flag that says so."""
    side = "below" if volume.gradient_direction == "ascent" else "above"
    if labels:
        return key, m   # a label's surface encloses the label
    if m.turned:
        side = "above" if side == "below" else "below"
        print(f"note: level {key['level']:g}: the object is {side} the level, not "
              f"{'above' if side == 'below' else 'below'} as {volume.name} was taken (its surface encloses the "
              f"values {side} it): its volume is given; --inside {side} says so", file=sys.stderr)
    return dict(key, inside=side), m


def _finite_or_none(point) -> list[float] | None:
    """A bounding-box corner, or None (JSON null) for a level that cuts nothing."""
    return [float(v) for v in point] if all(math.isfinite(v) for v in point) else None
