"""`isoscope export`: mesh files of one or several levels, of label maps, chunked or on dask workers."""
from __future__ import annotations

import os
import sys
from pathlib import Path

from ..errors import InputError
from ..validation import as_gradient_direction
from .common import LABEL_MESH_FLAGS, check_label_options, checked_levels, count_line, level_path, progress, wrote
from .volume_options import each_time_point, open_volume_from_args


def max_workers() -> int:
    """--workers at most: each worker is a process with its own OpenGL context and chunk buffers."""
    return max(4, 4 * (os.cpu_count() or 1))


def _check_workers(args) -> None:
    """--workers within 1..max_workers(), refused before the volume is read."""
    if args.workers is not None and args.workers < 1:
        raise InputError(f"--workers {args.workers}: give 1 or more worker processes")
    if args.workers is not None and args.workers > max_workers():
        raise InputError(f"--workers {args.workers} is more worker processes than this machine runs "
                         f"({os.cpu_count()} cores: at most {max_workers()}); give fewer, or --scheduler for a "
                         "cluster of machines")
    if args.workers is not None and args.scheduler is not None:
        raise InputError("--workers starts a local cluster, --scheduler uses another one; give one of them")


def _extract_for_export(volume, iso, args):
    """The export's mesh: whole, a chunk at a time here, or a chunk per task on a dask cluster."""
    from ..core.lazy_arrays import is_lazy
    from ..options import MeshOptions
    distributed = args.scheduler is not None or args.workers is not None
    chunked = args.chunk is not None or distributed or is_lazy(volume.data)
    problem = MeshOptions(cells="tetrahedra" if args.tetrahedra else "cubes", smooth=args.smooth, sharp=args.sharp,
                          chunked=chunked, topology=getattr(args, "topology", None) or "montani").problem()
    if problem is not None:
        why = "" if not chunked else ("this export is chunked (--chunk, --workers, --scheduler, or a Zarr or "
                                      "memory-mapped volume): ")
        raise InputError(why + problem)
    closed = getattr(args, "closed", False)
    if closed and chunked:
        raise InputError("--closed pads the whole volume, and this export is chunked (--chunk, --workers, "
                         "--scheduler, or a Zarr or memory-mapped volume); leave out --closed, or the chunking")
    if not chunked:
        return _whole(volume, iso, args, closed)
    from ..big.chunked import DEFAULT_CHUNK, as_chunks, marching_cubes_chunked
    from ..validation import as_level
    chunks = as_chunks(DEFAULT_CHUNK if args.chunk is None else args.chunk, volume.data.shape)
    level = as_level(iso, volume.value_range)
    descent = as_gradient_direction(volume.gradient_direction)
    topology = getattr(args, "topology", None) or "montani"
    if distributed:
        from ..big.cluster import marching_cubes_on_cluster
        return marching_cubes_on_cluster(volume.data, level, volume.spacing, descent, chunks,
                                         scheduler=args.scheduler, workers=args.workers, progress=progress,
                                         path=volume.source, topology=topology)
    return marching_cubes_chunked(volume.data, level, volume.spacing, descent, chunks, progress=progress,
                                  topology=topology)


def _whole(volume, iso, args, closed: bool):
    """The whole volume's mesh in one extraction; `closed`: of the volume padded on the outside of the level,
    so capped where it leaves the volume."""
    from ..one_shot import closed_mesh, extraction_of
    cells = "tetrahedra" if args.tetrahedra else "cubes"
    topology = getattr(args, "topology", None) or "montani"
    if closed:
        return closed_mesh(volume, iso, cells, args.smooth, topology, sharp=args.sharp, backend="auto")
    options = {} if args.sharp is None else {"sharp_features": args.sharp}
    return extraction_of(cells, topology)(volume.checked, iso, spacing=volume.spacing,
                                          gradient_direction=volume.gradient_direction, smooth=args.smooth, **options)


def _export_open_options(args) -> dict:
    """An export that is not chunked hands an in-memory volume to one extractor: a file whose header
    says it is bigger is refused from the header, before gigabytes are read for nothing. One on a dask
    cluster maps a raw file whatever its size, so its workers read it by name."""
    if args.workers is not None or args.scheduler is not None:
        return {"map_files": True}
    if args.chunk is not None:
        return {}
    from ..core.layout import MAX_WORDS, WORD_BITS, fits_one_extraction
    return dict(fits=fits_one_extraction,
                fits_refusal=f"more than one extraction takes ({MAX_WORDS * WORD_BITS:,}, in rows of whole "
                             f"{WORD_BITS}-sample words): export it a chunk at a time (--chunk 128), or crop or "
                             "downsample it")


def run_export(args) -> int:
    """``isoscope export``: check the options (the format by --out's extension first), then write the mesh of each level
    (one file per level, per time point with --time all or A:B), or each label's with --labels; the exit status."""
    if args.labels:
        return _export_labels(args)
    check_label_options(args, "--one-file", "--max-labels", "--label-names", "--force-labels")
    _check_workers(args)
    from ..io.export import mesh_format
    mesh_format(args.out)  # an unknown extension or fraction is refused before any work
    if args.decimate is not None:
        from ..cpu.decimate import check_fraction
        check_fraction(args.decimate)
    # --time all or A:B: one mesh (per level) per time point, STEM_t000.EXT
    for done, (time, volume) in enumerate(each_time_point(args.volume, args, progress, **_export_open_options(args))):
        _export_levels(volume, args, args.out if time is None else time_path(args.out, time))
        if time is not None:
            count_line(done + 1, len(args.time.points(volume.time_points)), "time point")
    return 0


def time_path(out, time: int) -> str:
    """Where export writes time point `time` of a series: STEM_t000.EXT beside `out`."""
    out = Path(out)
    return str(out.with_name(f"{out.stem}_t{time:03d}{out.suffix}"))


def _export_levels(volume, args, out) -> None:
    """The mesh of each --iso level of `volume` to `out` (STEM_iso<V>.EXT for several)."""
    from ..io.export import in_volume_space, write_mesh
    isos = checked_levels(volume, args.iso)
    for iso in isos:
        verts, faces, normals, _ = _extract_for_export(volume, iso, args)
        if args.decimate is not None:
            verts, faces, normals = _decimated(volume, iso, verts, faces, args.decimate)
        verts, faces, normals, space = in_volume_space(volume, verts, faces, normals, world=args.space == "world")
        path = write_mesh(out if len(isos) == 1 else level_path(out, iso), verts, faces, normals, space=space)
        wrote(path, f": {len(verts):,} vertices, {len(faces):,} triangles, in {space} coordinates")


def _export_labels(args) -> int:
    from ..labels import (
        DEFAULT_MAX_LABELS,
        TooManyLabels,
        check_label_output,
        label_file,
        refuse_a_scan,
        write_label_meshes,
    )
    check_label_options(args, "--iso", "--decimate", "--closed", *LABEL_MESH_FLAGS)   # closed already
    for option in ("--chunk", "--workers", "--scheduler"):
        if getattr(args, option.strip("-")) is not None:
            raise InputError(f"export --labels makes every label's surface here, from the whole volume; "
                             f"leave out {option}")
    if args.label_names is not None and not args.one_file:
        raise InputError("--label-names gives the colours of --one-file's vertices (a file per label holds no "
                         "colour); add --one-file")
    check_label_output(args.out, args.one_file)
    volume = open_volume_from_args(args.volume, args, progress)
    refuse_a_scan(volume, args.force_labels)   # before a file is written
    limit = DEFAULT_MAX_LABELS if args.max_labels is None else args.max_labels
    try:
        names = _label_names(volume, args) if args.one_file else {}
        if names:
            written = _write_named_labels(volume, args.out, names, args.space == "world", limit)
        else:
            written = write_label_meshes(volume, args.out, one_file=args.one_file, world=args.space == "world",
                                         max_labels=limit)
    except TooManyLabels as exc:
        would = (f"one file holding {exc.count} meshes" if args.one_file else
                 f"{exc.count} files ({label_file(args.out, 'N').name})")
        raise InputError(f"{volume.name} has {exc.count} distinct non-zero values, more than --max-labels {limit}: "
                         f"--labels would write {would}; if it is a scan, not a segmentation, leave out --labels; "
                         f"if it is a label map, raise the limit with --max-labels {exc.count}") from None
    space = volume.world[1] if args.space == "world" and volume.world is not None else "index x spacing"
    for path, n_vertices, n_triangles in written:
        wrote(path, f": {n_vertices:,} vertices, {n_triangles:,} triangles, in {space} coordinates")
    return 0


def _label_names(volume, args) -> dict:
    """The label names file's entries (--label-names, else the one beside the segmentation; {} if none)."""
    from ..volumes.label_names import label_names_for
    return label_names_for(volume.source, args.label_names)


def _write_named_labels(volume, out, names: dict, world: bool, limit):
    """One PLY/GLB of every label's surface, each vertex in its label's colour as the viewer draws it (the
    names file's where it lists the label, else the default palette over the labels in order)."""
    from ..io.export import in_volume_space
    from ..labels import label_surfaces, labels_of, write_labelled
    from ..viewer.model.labels import layers
    surfaces = label_surfaces(labels_of(volume), spacing=volume.spacing, max_labels=limit)
    if not surfaces:
        raise InputError(f"{volume.name} has no non-zero labels, so no surface to write; leave out --labels "
                         "to export an isosurface")
    placed = {label: in_volume_space(volume, *mesh, world=world) for label, mesh in surfaces.items()}
    colors = [layer.color for layer in layers(list(placed), names)]
    space = next(iter(placed.values()))[3]
    return write_labelled(out, {label: mesh[:3] for label, mesh in placed.items()}, colors, space, True)


def _decimated(volume, iso, verts, faces, fraction):
    from ..cpu.decimate import decimate, distance_off_level_set, open_edges
    level = volume.value_range[0] + (volume.value_range[1] - volume.value_range[0]) / 2 if iso is None else iso
    full_triangles, full_open = len(faces), open_edges(faces)
    verts, faces, normals = decimate(verts, faces, fraction)
    off = distance_off_level_set(volume.checked.data, volume.spacing, level, verts)  # a lazy volume read whole
    print(f"decimated {full_triangles:,} -> {len(faces):,} triangles; distance off the level set: "
          f"max {off.max():.3g}, mean {off.mean():.3g} (world units; voxel {min(volume.spacing):.3g})")
    now_open = open_edges(faces)
    if now_open > full_open:
        print(f"note: the decimated mesh has {now_open} open edges where the full mesh had {full_open}",
              file=sys.stderr)
    return verts, faces, normals
