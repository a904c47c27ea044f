"""Scenes and models: a scene is its source (a built-in name or a YAML file) and its overrides, read
by the library's own parser (the rules and messages of `cariesim scene check`)."""

import math

from . import _cariesim


def builtin_scenes():
    """The built-in scenes' names, the default first."""
    return list(_cariesim.builtin_scene_names())


def format_value(value):
    """An override's value as the YAML text the scene reader reads: numbers exactly (the shortest text
    that reads back to the same float), booleans as true/false, text as given (YAML: "rigid",
    "{gradient: {top: 1, bottom: 3}}"), lists and dicts as YAML flow collections."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        # repr is the shortest exact form; nan and inf are left for the reader to refuse.
        return repr(value) if math.isfinite(value) else str(value)
    if isinstance(value, str):
        return value
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(format_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {format_value(v)}" for k, v in value.items()) + "}"
    try:  # numpy scalars
        return format_value(value.item())
    except AttributeError:
        raise TypeError(f"override value {value!r}: expected a number, bool, text, list or dict") from None


class Scene:
    """A validated scene: `source` (built-in name or YAML path) with `overrides` (key -> value) applied
    in order. Picklable (it is its source and overrides), so sweeps send it to other processes."""

    def __init__(self, source, overrides=None):
        self.source = str(source)
        self.overrides = dict(overrides or {})
        pairs = [(str(k), format_value(v)) for k, v in self.overrides.items()]
        self._desc = _cariesim.load_scene_desc(self.source, pairs)

    def __reduce__(self):
        return (Scene, (self.source, self.overrides))

    def __repr__(self):
        extra = f", overrides={self.overrides!r}" if self.overrides else ""
        return f"cariesim.Scene({self.source!r}{extra})"

    name = property(lambda self: self._desc.name, doc="The scene's name.")
    origin = property(lambda self: self._desc.origin, doc="The file, or builtin:NAME.")
    description = property(lambda self: self._desc.description)
    servo_rate = property(lambda self: self._desc.servo_rate, doc="Hz, the scene's servo rate.")
    source_hash = property(lambda self: self._desc.source_hash, doc="Hash of the text and overrides.")
    objects = property(lambda self: list(self._desc.object_names), doc="The objects' names.")
    lesions = property(lambda self: list(self._desc.lesion_names), doc="The lesions' names.")
    lesion_materials = property(lambda self: list(self._desc.lesion_materials),
                                doc="Each lesion's material as a dict (scene-format names).")

    def with_overrides(self, overrides):
        """A new scene with `overrides` ({"lesions[0].material.k_c": 0.4, ...}) applied after this
        one's; raises cariesim.Error (file, override, field) on an unknown key or a bad value."""
        merged = dict(self.overrides)
        merged.update(overrides)
        return Scene(self.source, merged)

    def build(self, progress=None, cache=True, cache_dir=None, measure_deviation=False):
        """Builds the model (sphere trees from the tree cache when there, else built and cached).
        `progress(stage, fraction)` is called as it goes; the GIL is released while building."""
        built = _cariesim.build_model(self._desc, progress, bool(cache), str(cache_dir or ""),
                                      bool(measure_deviation))
        return Model(built, self)


def load_scene(source, overrides=None):
    """A built-in scene by name or a scene YAML file, optionally with overrides."""
    return Scene(source, overrides)


class Model:
    """A built model: immutable; Simulator(model) runs it."""

    def __init__(self, built, scene):
        self._built = built
        self.scene = scene

    servo_rate = property(lambda self: self._built.servo_rate, doc="Hz, the scene's servo rate.")
    lesion_count = property(lambda self: self._built.lesion_count)
    tip_radius = property(lambda self: self._built.tip_radius, doc="mm, the explorer's tip sphere.")
    tool_home = property(lambda self: list(self._built.tool_home),
                         doc="The tool's home pose [px, py, pz (mm), qw, qx, qy, qz].")
    scene_hash = property(lambda self: self._built.scene_hash)
    defaults = property(lambda self: self._built.defaults, doc="A copy of the authored Params.")
    parts = property(lambda self: self._built.parts,
                     doc="Per part: leaves, levels, build time, cache hit, surface deviation (mm) "
                         "when built with measure_deviation=True.")

    def trees(self):
        """Per collision object: name, lesion, and its leaves as arrays: centres (N x 3, mm), radii
        (mm), material index, tissue code (cariesim.tissue_names())."""
        return self._built.trees()


class Simulator(_cariesim.Simulator):
    """The haptic step over a model at a fixed rate (Hz; default the scene's).

    run(trajectory): the whole N x 8 trajectory (t s, px py pz mm, qw qx qy qz) from a fresh state, as
    `cariesim sim` runs it (the same C++ function), into a structured array whose fields are sim's CSV
    columns; the GIL is released while it runs. step(pose): one servo cycle at a pose (px py pz qw qx
    qy qz), carrying the state from call to call (reset() starts again). `params` are the running
    Params (Params.set checks values as the sliders do); run and step use them.
    """

    def __init__(self, model, rate=None):
        super().__init__(model._built, float(rate or 0.0))
        self.model = model
