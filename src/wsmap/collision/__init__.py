"""Maps a robot can use: self-collision and obstacles from the arm's own collision geometry.

* `.shapes` — one record per kind of shape (`SHAPE_KINDS`: box, cylinder, sphere, capsule, mesh): its
  sizes, bounding spheres, coal geometry and readers (URDF, MJCF, scene files); a new kind is one
  new module there;
* `.geometry` — the collision model of an arm: shapes on the bodies of its chain, from a
  URDF's `<collision>` elements (`from_urdf_collision`), capsules (`capsule_model`,
  `capsules_along_links` for a DH arm with link radii);
* `.named` — models of the named arms (`arm_model`: capsules fitted to the vendor's meshes, the
  meshes themselves, or estimated capsules);
* `.vendor` — the vendor collision meshes of the Panda, the iiwa 14, the UR5e, the UR10e and the Gen3 (one
  record per arm, `VENDOR`) and the capsules fitted to them;
* `.acm` — the allowed-collision matrix (`build_acm`, as MoveIt's setup assistant);
* `.scene` — obstacles: the floor, boxes, cylinders, spheres, meshes (`Scene`,
  `load_scene` from YAML/JSON), and those of a work cell's URDF (`scene_from_urdf`:
  fixed links with `<collision>` elements, in the world frame or the frame of the link the arm
  is mounted on; `load_scene` by the suffix `.urdf`);
* `.checks` — `CollisionChecker`, a configuration predicate (a batch of `q` → bool
  free): spheres first, coal's exact test where they say "maybe";
* `.fields` — checked numbers of URDF attributes and `<origin>` elements and of scene-file values;
  `.errors` — `CollisionError`, raised by all of them.

The maps take the checker as `collision=` (`wsmap.workspace.constant_orientation_map`,
`wsmap.reachable`, `wsmap.workspace.reachability_index`): a node counts only with a
joint solution inside the limits, confirmed by forward kinematics and collision-free.
"""

from .acm import ACM, DEFAULT_SAMPLES, REASONS, build_acm
from .checks import CheckStats, CollisionChecker, bounding_spheres, exact_pairs
from .geometry import (SHAPES, CollisionError, CollisionModel, Link, Shape, body_frames, capsule_model,
                       capsules_along_links, from_urdf_collision, read_mesh)
from .named import ARM_MODELS, arm_model, default_geometry
from .scene import Obstacle, Scene, load_scene, scene_from_dict, scene_from_urdf
from .shapes import SHAPE_KINDS, ShapeKind, shape_kind

__all__ = ["ACM", "DEFAULT_SAMPLES", "REASONS", "build_acm", "CheckStats", "CollisionChecker", "bounding_spheres",
           "exact_pairs", "SHAPES", "CollisionError", "CollisionModel", "Link", "Shape", "body_frames",
           "capsule_model", "capsules_along_links", "from_urdf_collision", "read_mesh", "ARM_MODELS", "arm_model", "default_geometry",
           "Obstacle", "Scene", "load_scene", "scene_from_dict", "scene_from_urdf", "SHAPE_KINDS", "ShapeKind",
           "shape_kind", "checker_for"]


def checker_for(robot_name_or_model, scene=None, *, link_radius=None, geometry=None,
                **acm_settings) -> CollisionChecker:
    """A `CollisionChecker` for a named arm (its model in `geometry`: `"meshes"`, `"two-level"`,
    `"fitted"` or `"capsules"`, default `default_geometry`: the vendor meshes where they are
    installed; `wsmap.collision.named`), a
    `CollisionModel`, or any arm with `link_radius` (m; one or one per body: capsules along its
    links, `capsules_along_links`), with `scene` (default: the model's floor) and the matrix
    built with `acm_settings` (`build_acm`: `samples`, `seed`, `disable`; a fitted model
    carries the matrix of its vendor meshes, and so do the meshes and the two-level model)."""
    if geometry is not None and not isinstance(robot_name_or_model, str):
        raise CollisionError("geometry= chooses the model of a named arm: give its name")
    if link_radius is not None:
        model = capsules_along_links(robot_name_or_model, link_radius)
    elif isinstance(robot_name_or_model, CollisionModel):
        model = robot_name_or_model
    elif isinstance(robot_name_or_model, str):
        name = robot_name_or_model
        model = arm_model(name, geometry=default_geometry(name) if geometry is None else geometry)
    else:
        raise CollisionError(f"{getattr(robot_name_or_model, 'name', None) or 'this arm'} has no collision model: "
                             "give a named arm, a CollisionModel, or link_radius=")
    if acm_settings or model.acm is None:
        model.acm = build_acm(model, **acm_settings)
    return CollisionChecker(model, scene)
