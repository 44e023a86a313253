"""Every rerun call of calibench lives here (rerun-sdk's API moves between minor versions).

Entity layout, shared by the scenarios:

- ``world/<body>``: MuJoCo bodies as meshes (trimesh), their poses on the scenario's timeline
- ``world/camera``: the camera's pose and pinhole; ``world/camera/image`` its images, with
  ``.../detected`` and ``.../true`` corner points
- ``error_map/...``: error vectors and residual series
- ``report``: the truth-versus-estimate table (Markdown)

World units are metres (MuJoCo's); a scenario converts before logging. trimesh and OpenCV are
imported by the functions that use them: a study's log (a figure and a table) does without the
half second they take to load.
"""

from __future__ import annotations

import contextlib
import dataclasses
import errno
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

# rerun's own log lines (coloured, several for one failed write) are not calibench's answer:
# a failure to write is raised and said in one line
os.environ.setdefault("RUST_LOG", "off")
import rerun as rr  # noqa: E402

from calibench.writing import replaced  # noqa: E402

if TYPE_CHECKING:
    import trimesh

RED = (230, 60, 50)
GREEN = (40, 200, 90)
BLUE = (50, 120, 230)
ORANGE = (245, 160, 40)


# --- layouts ---------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class View:
    """One view of a scenario's layout (plain data; :func:`blueprint` makes rerun's).

    kind : "3d", "2d" (an image with its points, or a figure), "plot" (scalars over the
        layout's timeline) or "text".
    origin : the entity the view is rooted at; contents : rerun's path expressions ("+ a/**",
        "- a/b/**"), default the origin's subtree.
    eye : "3d" only: (position (3,), look_target (3,)) in metres, to open framed on the machine.
    """

    kind: str
    origin: str
    name: str
    contents: tuple[str, ...] = ()
    eye: tuple | None = None


def eye_on(model, direction=(1.0, -1.4, 0.8)) -> tuple:
    """A camera position looking at a MuJoCo model's machine from ``direction`` (in units of its
    size): the bounding sphere of every geom but the planes (a floor would frame the horizon),
    so the 3-D view opens on the machine, not on the whole world."""
    import mujoco

    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    solid = model.geom_type != mujoco.mjtGeom.mjGEOM_PLANE
    if not solid.any():
        solid[:] = True
    lo = (data.geom_xpos[solid] - model.geom_rbound[solid, None]).min(axis=0)
    hi = (data.geom_xpos[solid] + model.geom_rbound[solid, None]).max(axis=0)
    centre, size = (lo + hi) / 2, float(np.linalg.norm(hi - lo)) / 2
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    return tuple(centre + 1.8 * size * d), tuple(centre)


def blueprint(columns: list[list[View]], timeline: str) -> rr.blueprint.Blueprint:
    """Columns of views side by side (each column's views stacked), on ``timeline``."""
    import rerun.blueprint as rrb

    def make(v: View):
        kw: dict[str, Any] = {"origin": v.origin, "name": v.name}
        if v.contents:
            kw["contents"] = list(v.contents)
        if v.kind == "3d":
            if v.eye is not None:
                kw["eye_controls"] = rrb.EyeControls3D(
                    position=v.eye[0], look_target=v.eye[1], eye_up=(0, 0, 1)
                )
            return rrb.Spatial3DView(**kw)
        if v.kind == "2d":
            return rrb.Spatial2DView(**kw)
        if v.kind == "plot":
            return rrb.TimeSeriesView(**kw)
        if v.kind == "text":
            return rrb.TextDocumentView(**kw)
        raise ValueError(f"unknown view kind {v.kind!r}")

    cols = [
        rrb.Vertical(*[make(v) for v in col]) if len(col) > 1 else make(col[0]) for col in columns
    ]
    return rrb.Blueprint(
        rrb.Horizontal(*cols),
        rrb.TimePanel(timeline=timeline),
        rrb.BlueprintPanel(expanded=False),
        rrb.SelectionPanel(expanded=False),
    )


def send_layout(rec: rr.RecordingStream, columns: list[list[View]], timeline: str) -> None:
    """Send the scenario's layout with the recording: the viewer opens on it."""
    rec.send_blueprint(blueprint(columns, timeline), make_active=True, make_default=True)


# each open recording's (temporary file, its name): written beside, renamed when closed whole
_WRITING: dict[int, tuple[contextlib.AbstractContextManager[Path], Path, Path]] = {}


def open_recording(path: Path, application_id: str) -> rr.RecordingStream:
    """A recording stream that writes to ``path`` (an .rrd file), whole or not at all: to a
    temporary file beside it, renamed by :func:`close`."""
    rec = rr.RecordingStream(application_id, recording_id=f"{application_id}-{path.parent.name}")
    writing = replaced(path)
    tmp = writing.__enter__()
    _WRITING[id(rec)] = (writing, tmp, path)
    rec.save(str(tmp))
    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    return rec


def close(rec: rr.RecordingStream) -> None:
    """Flush and close the recording, and put it in place; OSError where rerun's writer stopped
    (a full disk, a file-size limit: its own messages are silenced, RUST_LOG above)."""
    writing, tmp, path = _WRITING.pop(id(rec))
    try:
        rec.flush()
    except RuntimeError:  # rerun says only that its file writer stopped: the disk says why
        rec.disconnect()
        code = _why_unwritten(tmp)
        tmp.unlink(missing_ok=True)
        raise OSError(code, os.strerror(code), str(path)) from None
    rec.disconnect()
    writing.__exit__(None, None, None)


def _why_unwritten(tmp: Path) -> int:
    """The errno of a recording rerun could not write: a full disk, a file-size limit, or EIO."""
    import resource

    st = os.statvfs(tmp.parent)
    if st.f_bavail * st.f_frsize < 1 << 20:
        return errno.ENOSPC
    limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    if limit != resource.RLIM_INFINITY and tmp.stat().st_size >= limit - (1 << 16):
        return errno.EFBIG
    return errno.EIO


def set_step(rec: rr.RecordingStream, timeline: str, step: int) -> None:
    """Log what follows at ``step`` of ``timeline`` only: an earlier phase's timeline (the
    calibration's views before the stations) would otherwise stamp every later point with its
    last value, and plots on it would show all points at one instant."""
    rec.reset_time()
    rec.set_time(timeline, sequence=int(step))


# --- geometry ------------------------------------------------------------------------------
def _geom_mesh(model, g: int) -> trimesh.Trimesh | None:
    import mujoco  # only for the enum values; the world is already built
    import trimesh

    t = model.geom_type[g]
    size = model.geom_size[g]
    if t == mujoco.mjtGeom.mjGEOM_BOX:
        mesh = trimesh.creation.box(extents=2 * size)
    elif t == mujoco.mjtGeom.mjGEOM_PLANE:
        mesh = trimesh.creation.box(extents=[2 * size[0], 2 * size[1], 1e-4])
    elif t == mujoco.mjtGeom.mjGEOM_SPHERE:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=size[0])
    elif t == mujoco.mjtGeom.mjGEOM_CYLINDER:
        mesh = trimesh.creation.cylinder(radius=size[0], height=2 * size[1], sections=32)
    elif t == mujoco.mjtGeom.mjGEOM_CAPSULE:
        mesh = trimesh.creation.capsule(radius=size[0], height=2 * size[1])
    else:
        return None
    T = np.eye(4)
    T[:3, :3] = trimesh.transformations.quaternion_matrix(model.geom_quat[g])[:3, :3]
    T[:3, 3] = model.geom_pos[g]
    mesh.apply_transform(T)
    return mesh


def log_mujoco_bodies(
    rec: rr.RecordingStream,
    model,
    root: str = "world",
    textures: dict[str, np.ndarray] | None = None,
    skip=lambda name: False,
) -> dict[int, str]:
    """Log every body's geoms once (static, in the body frame). Returns body id -> entity path.

    ``textures`` maps a box geom's name to an image (h, w, 3) drawn on its +z face as MuJoCo
    draws a 2-D texture there (e.g. a calibration plate); geoms whose name ``skip`` accepts are
    left out (many small ones a scenario draws better itself).
    """
    import trimesh

    paths = nested_paths(model, root)
    textures = textures or {}
    per_body = np.bincount(model.geom_bodyid, minlength=model.nbody)
    merged: dict[tuple, list] = {}  # (parent, rgba) -> meshes of a body with many geoms
    for g in range(model.ngeom):
        b = model.geom_bodyid[g]
        gname = model.geom(g).name or f"geom{g}"
        if skip(gname):
            continue
        parent = paths.get(b, root)
        if gname in textures:
            _log_textured_top(rec, f"{parent}/{gname}", model, g, textures[gname])
            continue
        mesh = _geom_mesh(model, g)
        if mesh is None:
            continue
        mat = model.geom_matid[g]
        rgba = tuple(
            (np.asarray(model.mat_rgba[mat] if mat >= 0 else model.geom_rgba[g]) * 255).astype(
                np.uint8
            )
        )
        if per_body[b] > MERGE_ABOVE:  # e.g. the probe scanner's walls: one entity, not thousands
            merged.setdefault((parent, rgba), []).append(mesh)
            continue
        _log_mesh(rec, f"{parent}/{gname}", mesh, rgba)
    for k, ((parent, rgba), meshes) in enumerate(merged.items()):
        # concatenate is typed to return a Geometry: of Trimeshes it is a Trimesh
        whole = cast("trimesh.Trimesh", trimesh.util.concatenate(meshes))
        _log_mesh(rec, f"{parent}/merged_{k}", whole, rgba)
    return paths


MERGE_ABOVE = 20  # a body with more geoms than this is logged as one mesh per colour


def _log_mesh(rec, path: str, mesh: trimesh.Trimesh, rgba) -> None:
    rec.log(
        path,
        rr.Mesh3D(
            vertex_positions=mesh.vertices,
            triangle_indices=mesh.faces,
            vertex_normals=mesh.vertex_normals,
            albedo_factor=np.asarray(rgba, np.uint8),
        ),
        static=True,
    )


def _log_textured_top(rec, path, model, g, image):
    import trimesh

    hx, hy, hz = model.geom_size[g]
    R = trimesh.transformations.quaternion_matrix(model.geom_quat[g])[:3, :3]
    corners = (
        np.array([[-hx, -hy, hz], [hx, -hy, hz], [hx, hy, hz], [-hx, hy, hz]]) @ R.T
        + model.geom_pos[g]
    )
    log_textured_quad(rec, path, corners, image)


def log_textured_quad(
    rec: rr.RecordingStream, path: str, corners: np.ndarray, image: np.ndarray
) -> None:
    """A flat quad (corners (4, 3): -x-y, +x-y, +x+y, -x+y of its own frame) showing ``image``
    with row 0 along its +y edge, as MuJoCo draws a 2-D texture on a box face."""
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], float)  # rerun's texcoord v = 0 is row 0
    normal = np.cross(corners[1] - corners[0], corners[3] - corners[0])
    normal /= np.linalg.norm(normal)
    rec.log(
        path,
        rr.Mesh3D(
            vertex_positions=corners,
            triangle_indices=[[0, 1, 2], [0, 2, 3]],
            vertex_normals=np.tile(normal, (4, 1)),
            vertex_texcoords=uv,
            albedo_texture=image,
        ),
        static=True,
    )


def log_body_poses(
    rec: rr.RecordingStream,
    paths: dict[int, str],
    xpos: np.ndarray,
    xquat: np.ndarray,
    parent_of: np.ndarray,
) -> None:
    """Body poses relative to their parents (MuJoCo ``xpos``/``xquat`` are world poses)."""
    import trimesh

    for b, path in paths.items():
        p = parent_of[b]
        R_w = trimesh.transformations.quaternion_matrix(xquat[b])[:3, :3]
        if p == 0:
            t, R = xpos[b], R_w
        else:
            R_p = trimesh.transformations.quaternion_matrix(xquat[p])[:3, :3]
            t, R = R_p.T @ (xpos[b] - xpos[p]), R_p.T @ R_w
        rec.log(path, rr.Transform3D(translation=t, mat3x3=R))


def nested_paths(model, root: str = "world") -> dict[int, str]:
    """Entity paths that follow MuJoCo's body tree, so child transforms compose."""
    out: dict[int, str] = {}
    for b in range(1, model.nbody):
        p = model.body_parentid[b]
        name = model.body(b).name or f"body{b}"
        out[b] = f"{out[p] if p in out else root}/{name}"
    return out


# --- cameras and images --------------------------------------------------------------------
def log_camera(
    rec: rr.RecordingStream,
    path: str,
    K: np.ndarray,
    size: tuple[int, int],
    cam2world_R: np.ndarray,
    cam2world_t: np.ndarray,
    static: bool = True,
) -> None:
    """Pinhole (OpenCV frame: x right, y down, z forward) at a pose in its parent."""
    rec.log(path, rr.Transform3D(translation=cam2world_t, mat3x3=cam2world_R), static=static)
    rec.log(
        path,
        rr.Pinhole(
            image_from_camera=K,
            resolution=list(size),
            camera_xyz=rr.ViewCoordinates.RDF,
            image_plane_distance=0.3,
        ),
        static=static,
    )


def log_image(rec: rr.RecordingStream, path: str, image: np.ndarray) -> None:
    """An RGB image, stored losslessly as PNG."""
    import cv2

    ok, buf = cv2.imencode(".png", image[..., ::-1] if image.ndim == 3 else image)
    rec.log(path, rr.EncodedImage(contents=buf.tobytes(), media_type="image/png"))


def log_points2d(
    rec: rr.RecordingStream, path: str, pts: np.ndarray, color, radius: float = 1.5
) -> None:
    """2-D points (n, 2) px under an image."""
    pts = np.asarray(pts, float).reshape(-1, 2)
    pts = pts[np.isfinite(pts).all(axis=1)]
    rec.log(path, rr.Points2D(pts, colors=color, radii=radius))


def log_points3d(
    rec: rr.RecordingStream,
    path: str,
    pts: np.ndarray,
    color,
    radius: float = 0.004,
    static: bool = False,
) -> None:
    """3-D points (n, 3) m."""
    rec.log(
        path,
        rr.Points3D(np.asarray(pts, float).reshape(-1, 3), colors=color, radii=radius),
        static=static,
    )


def log_arrows3d(
    rec: rr.RecordingStream,
    path: str,
    origins: np.ndarray,
    vectors: np.ndarray,
    color,
    static: bool = True,
    radius: float = 0.002,
) -> None:
    """Arrows from ``origins`` (n, 3) along ``vectors`` (n, 3), m."""
    rec.log(
        path,
        rr.Arrows3D(origins=origins, vectors=vectors, colors=color, radii=radius),
        static=static,
    )


def log_line_strips2d(rec: rr.RecordingStream, path: str, strips: list[np.ndarray], color) -> None:
    """2-D polylines, each (k, 2)."""
    rec.log(
        path, rr.LineStrips2D([np.asarray(s, float) for s in strips], colors=color), static=True
    )


def log_line_strips3d(
    rec: rr.RecordingStream, path: str, strips: list[np.ndarray], color, static: bool = True
) -> None:
    """3-D polylines, each (k, 3) m."""
    rec.log(
        path, rr.LineStrips3D([np.asarray(s, float) for s in strips], colors=color), static=static
    )


def log_scalar(rec: rr.RecordingStream, path: str, value: float) -> None:
    """One value of a plot at the current step."""
    rec.log(path, rr.Scalars([float(value)]))


def log_text(rec: rr.RecordingStream, path: str, markdown: str) -> None:
    """A Markdown document (the report's table)."""
    rec.log(path, rr.TextDocument(markdown, media_type=rr.MediaType.MARKDOWN), static=True)


def log_figure(rec: rr.RecordingStream, path: str, png: Path) -> None:
    """A PNG figure as an image."""
    rec.log(path, rr.EncodedImage(path=str(png)), static=True)


# --- reading back (tests, tools) ------------------------------------------------------------
def entity_paths(rrd: Path) -> set[str]:
    """Entity paths stored in an .rrd file (its data, not its layout)."""
    from rerun.chunk import RrdReader

    reader = RrdReader(str(rrd))
    return {str(c.entity_path) for c in reader.stream(store=reader.recordings()[0])}


def timelines(rrd: Path) -> dict[str, set[str]]:
    """Entity path -> the timelines its data are logged on (empty: static), of an .rrd file."""
    from rerun.chunk import RrdReader

    reader = RrdReader(str(rrd))
    out: dict[str, set[str]] = {}
    for c in reader.stream(store=reader.recordings()[0]):
        out.setdefault(str(c.entity_path), set()).update(c.timeline_names)
    return out


def layout_views(rrd: Path) -> list[dict]:
    """The views of the layout an .rrd file carries: kind (rerun's class: 3D, 2D, TimeSeries,
    TextDocument), name and origin, in no particular order."""
    from rerun.chunk import RrdReader

    reader = RrdReader(str(rrd))
    views = []
    for store in reader.blueprints():
        for c in reader.stream(store=store):
            rb = c.to_record_batch()
            names = rb.schema.names
            if "ViewBlueprint:class_identifier" not in names:
                continue
            col = {
                k: rb.column(f"ViewBlueprint:{k}").to_pylist()[-1]
                for k in ("class_identifier", "display_name", "space_origin")
                if f"ViewBlueprint:{k}" in names
            }
            views.append(
                {
                    "kind": col["class_identifier"][0],
                    "name": (col.get("display_name") or [""])[0],
                    "origin": (col.get("space_origin") or [""])[0],
                }
            )
    return views


def transforms(rrd: Path, timeline: str) -> dict[str, dict[int, tuple[np.ndarray, np.ndarray]]]:
    """Entity path -> step of ``timeline`` -> the logged (translation (3,), rotation (3, 3)) of
    every Transform3D an .rrd file holds on that timeline."""
    from rerun.chunk import RrdReader

    reader = RrdReader(str(rrd))
    out: dict[str, dict] = {}
    for c in reader.stream(store=reader.recordings()[0]):
        if timeline not in c.timeline_names:
            continue
        rb = c.to_record_batch()
        if "Transform3D:translation" not in rb.schema.names:
            continue
        steps = rb.column(timeline).to_pylist()
        ts = rb.column("Transform3D:translation").to_pylist()
        ms = rb.column("Transform3D:mat3x3").to_pylist()
        d = out.setdefault(str(c.entity_path), {})
        for k, t, m in zip(steps, ts, ms):
            d[int(k)] = (np.asarray(t[0], float), np.asarray(m[0], float).reshape(3, 3))
    return out
