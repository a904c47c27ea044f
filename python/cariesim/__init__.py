"""cariesim for researchers: scenes, models, the haptic step and the paper's experiments from Python,
numpy arrays in and out (docs/python.md).

    import cariesim
    scene = cariesim.load_scene("friction-block")
    scene = scene.with_overrides({"objects[0].material.stiffness": 2.0})
    model = scene.build()
    sim = cariesim.Simulator(model, rate=1000.0)
    out = sim.run(traj)          # traj: N x 8 (t, px, py, pz, qw, qx, qy, qz); out: sim's CSV columns
"""

from . import _cariesim
from ._errors import Error
from ._scene import Model, Scene, Simulator, load_scene, builtin_scenes, format_value
from ._cariesim import Params, UNIT_TOLERANCE, tissue_names
from ._records import read_recording, read_studies, STATE_NAMES
from ._experiments import experiment_names, run_experiment, friction, boundary, insertion, oral
from ._sweep import sweep, grid_points

__all__ = [
    "Error", "Model", "Scene", "load_scene", "builtin_scenes", "format_value", "Params", "Simulator",
    "UNIT_TOLERANCE", "tissue_names", "read_recording", "read_studies", "STATE_NAMES", "experiment_names",
    "run_experiment", "friction", "boundary", "insertion", "oral", "sweep", "grid_points",
    "sim_dtype",
]


def sim_dtype():
    """The numpy dtype of Simulator.run's rows: `cariesim sim`'s CSV columns."""
    return _cariesim.sim_dtype()
