"""Every rerun call of calibench lives here (rerun-sdk's API moves between minor versions).

Entity layout, shared by the scenarios:

- ``world/<body>``: MuJoCo bodies as meshes (trimesh), their poses on the scenario's timeline
- ``world/camera``: the camera's pose and pinhole; ``world/camera/image`` its images, with
  ``.../detected`` and ``.../true`` corner points
- ``error_map/...``: error vectors and residual series
- ``report``: the truth-versus-estimate table (Markdown)

World units are metres (MuJoCo's); a scenario converts before logging.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import rerun as rr
import trimesh

RED = (230, 60, 50)
GREEN = (40, 200, 90)
BLUE = (50, 120, 230)
ORANGE = (245, 160, 40)


def open_recording(path: Path, application_id: str) -> rr.RecordingStream:
    """A recording stream that writes to ``path`` (an .rrd file)."""
    rec = rr.RecordingStream(application_id, recording_id=f"{application_id}-{path.parent.name}")
    rec.save(str(path))
    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    return rec


def close(rec: rr.RecordingStream) -> None:
    rec.flush()
    rec.disconnect()


def set_step(rec: rr.RecordingStream, timeline: str, step: int) -> None:
    rec.set_time(timeline, sequence=int(step))


# --- geometry ------------------------------------------------------------------------------
def _geom_mesh(model, g: int) -> trimesh.Trimesh | None:
    import mujoco  # only for the enum values; the world is already built

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


def log_mujoco_bodies(rec: rr.RecordingStream, model, root: str = "world",
                      textures: dict[str, np.ndarray] | None = None, skip=lambda name: False) -> dict[int, str]:
    """Log every body's geoms once (static, in the body frame). Returns body id -> entity path.

    ``textures`` maps a box geom's name to an image (h, w, 3) drawn on its +z face as MuJoCo
    draws a 2-D texture there (e.g. a calibration plate); geoms whose name ``skip`` accepts are
    left out (many small ones a scenario draws better itself).
    """
    paths = nested_paths(model, root)
    textures = textures or {}
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
        rgba = model.mat_rgba[mat] if mat >= 0 else model.geom_rgba[g]
        rec.log(f"{parent}/{gname}", rr.Mesh3D(
            vertex_positions=mesh.vertices, triangle_indices=mesh.faces,
            vertex_normals=mesh.vertex_normals,
            albedo_factor=(np.asarray(rgba) * 255).astype(np.uint8)), static=True)
    return paths


def _log_textured_top(rec, path, model, g, image):
    hx, hy, hz = model.geom_size[g]
    R = trimesh.transformations.quaternion_matrix(model.geom_quat[g])[:3, :3]
    corners = np.array([[-hx, -hy, hz], [hx, -hy, hz], [hx, hy, hz], [-hx, hy, hz]]) @ R.T + model.geom_pos[g]
    log_textured_quad(rec, path, corners, image)


def log_textured_quad(rec: rr.RecordingStream, path: str, corners: np.ndarray, image: np.ndarray) -> None:
    """A flat quad (corners (4, 3): -x-y, +x-y, +x+y, -x+y of its own frame) showing ``image``
    with row 0 along its +y edge, as MuJoCo draws a 2-D texture on a box face."""
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], float)  # rerun's texcoord v = 0 is row 0
    normal = np.cross(corners[1] - corners[0], corners[3] - corners[0])
    normal /= np.linalg.norm(normal)
    rec.log(path, rr.Mesh3D(vertex_positions=corners, triangle_indices=[[0, 1, 2], [0, 2, 3]],
                            vertex_normals=np.tile(normal, (4, 1)), vertex_texcoords=uv,
                            albedo_texture=image), static=True)


def log_body_poses(rec: rr.RecordingStream, paths: dict[int, str], xpos: np.ndarray,
                   xquat: np.ndarray, parent_of: np.ndarray) -> None:
    """Body poses relative to their parents (MuJoCo ``xpos``/``xquat`` are world poses)."""
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
    out = {}
    for b in range(1, model.nbody):
        p = model.body_parentid[b]
        name = model.body(b).name or f"body{b}"
        out[b] = f"{out[p] if p in out else root}/{name}"
    return out


# --- cameras and images --------------------------------------------------------------------
def log_camera(rec: rr.RecordingStream, path: str, K: np.ndarray, size: tuple[int, int],
               cam2world_R: np.ndarray, cam2world_t: np.ndarray, static: bool = True) -> None:
    """Pinhole (OpenCV frame: x right, y down, z forward) at a pose in its parent."""
    rec.log(path, rr.Transform3D(translation=cam2world_t, mat3x3=cam2world_R), static=static)
    rec.log(path, rr.Pinhole(image_from_camera=K, resolution=list(size),
                             camera_xyz=rr.ViewCoordinates.RDF, image_plane_distance=0.3), static=static)


def log_image(rec: rr.RecordingStream, path: str, image: np.ndarray) -> None:
    """An RGB image, stored losslessly as PNG."""
    ok, buf = cv2.imencode(".png", image[..., ::-1] if image.ndim == 3 else image)
    rec.log(path, rr.EncodedImage(contents=buf.tobytes(), media_type="image/png"))


def log_points2d(rec: rr.RecordingStream, path: str, pts: np.ndarray, color, radius: float = 1.5) -> None:
    pts = np.asarray(pts, float).reshape(-1, 2)
    pts = pts[np.isfinite(pts).all(axis=1)]
    rec.log(path, rr.Points2D(pts, colors=color, radii=radius))


def log_points3d(rec: rr.RecordingStream, path: str, pts: np.ndarray, color, radius: float = 0.004,
                 static: bool = False) -> None:
    rec.log(path, rr.Points3D(np.asarray(pts, float).reshape(-1, 3), colors=color, radii=radius), static=static)


def log_arrows3d(rec: rr.RecordingStream, path: str, origins: np.ndarray, vectors: np.ndarray,
                 color, static: bool = True, radius: float = 0.002) -> None:
    rec.log(path, rr.Arrows3D(origins=origins, vectors=vectors, colors=color, radii=radius), static=static)


def log_line_strips2d(rec: rr.RecordingStream, path: str, strips: list[np.ndarray], color) -> None:
    rec.log(path, rr.LineStrips2D([np.asarray(s, float) for s in strips], colors=color), static=True)


def log_line_strips3d(rec: rr.RecordingStream, path: str, strips: list[np.ndarray], color,
                      static: bool = True) -> None:
    rec.log(path, rr.LineStrips3D([np.asarray(s, float) for s in strips], colors=color), static=static)


def log_scalar(rec: rr.RecordingStream, path: str, value: float) -> None:
    rec.log(path, rr.Scalars([float(value)]))


def log_text(rec: rr.RecordingStream, path: str, markdown: str) -> None:
    rec.log(path, rr.TextDocument(markdown, media_type=rr.MediaType.MARKDOWN), static=True)


def log_figure(rec: rr.RecordingStream, path: str, png: Path) -> None:
    rec.log(path, rr.EncodedImage(path=str(png)), static=True)


# --- reading back (tests, tools) ------------------------------------------------------------
def entity_paths(rrd: Path) -> set[str]:
    """Entity paths stored in an .rrd file."""
    from rerun.chunk import RrdReader

    return {str(c.entity_path) for c in RrdReader(str(rrd)).stream()}
