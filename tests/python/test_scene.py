"""Scenes from Python: loading, overrides (checked by the file's rules, with its messages), errors
carrying file, line, column and field, Params with the sliders' rules, pickling."""

import pickle

import pytest

import cariesim


def test_load_builtin_and_override():
    scene = cariesim.load_scene("friction-block")
    assert scene.origin == "builtin:friction-block"
    assert scene.lesions == ["top"]
    changed = scene.with_overrides({"objects[0].material.stiffness": 2.0, "lesions[0].material.k_c": 0.4})
    assert changed.lesion_materials[0]["k_c"] == 0.4
    assert scene.lesion_materials[0]["k_c"] != 0.4  # the original is unchanged
    assert changed.source_hash != scene.source_hash
    # Overrides accumulate; a later value of the same key wins.
    again = changed.with_overrides({"lesions[0].material.k_c": 0.5})
    assert again.lesion_materials[0]["k_c"] == 0.5
    assert again.overrides["objects[0].material.stiffness"] == 2.0


def test_structured_values():
    scene = cariesim.load_scene("friction-block",
                                {"lesions[0].material.k_c": {"gradient": {"top": 1.0, "bottom": 3.0}}})
    kc = scene.lesion_materials[0]["k_c"]
    assert kc["kind"] == "gradient" and kc["values"][:2] == [1.0, 3.0]


def test_file_errors_carry_their_location(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("objects:\n  - name: block\n    shape: {type: cuboid, size: [10, 20, 5]}\n"
                   "    material: {stiffness: -3}\n")
    with pytest.raises(cariesim.Error) as info:
        cariesim.load_scene(str(bad))
    e = info.value
    assert (e.file, e.line, e.column) == (str(bad), 4, 27)
    assert e.field == "objects[0].material.stiffness"
    assert e.message.startswith("-3 is out of range: expected > 0")
    assert isinstance(e, ValueError)


def _file_error(tmp_path, text):
    """The error of a scene file holding `text`."""
    path = tmp_path / "scene.yaml"
    path.write_text(text)
    with pytest.raises(cariesim.Error) as info:
        cariesim.load_scene(str(path))
    return info.value


BLOCK = ("objects:\n  - name: block\n    shape: {type: cuboid, size: [10, 20, 5]}\n    tissue: generic\n"
         "    material: {stiffness: 1.0}\n"
         "lesions:\n  - name: top\n    object: block\n    placement: {at: [0, 0, 2.5], normal: [0, 0, 1]}\n"
         "    shape: {type: disk, size: 3, depth: 1}\n    material: {k_c: 0.8}\n")


@pytest.mark.parametrize("key, value, written", [
    ("lesions[0].material.k_c", -1.0, "k_c: -1.0"),
    ("lesions[0].material.k_c", float("nan"), "k_c: nan"),
    ("lesions[0].material.kc", 1.0, "k_c: 0.8, kc: 1.0"),
    ("objects[0].material.stifness", 2.0, "stiffness: 1.0, stifness: 2.0"),
])
def test_overrides_fail_with_the_files_message(tmp_path, key, value, written):
    path = tmp_path / "base.yaml"
    path.write_text(BLOCK)
    with pytest.raises(cariesim.Error) as info:
        cariesim.load_scene(str(path)).with_overrides({key: value})
    e = info.value
    assert e.file == str(path) and e.override == key and e.line is None
    original = "k_c: 0.8" if key.startswith("lesions") else "stiffness: 1.0"
    from_file = _file_error(tmp_path, BLOCK.replace(original, written))
    assert (e.field, e.message) == (from_file.field, from_file.message)
    assert from_file.line is not None


def test_paths_that_do_not_fit():
    scene = cariesim.load_scene("friction-block")
    with pytest.raises(cariesim.Error, match=r"lesions has 1 entry"):
        scene.with_overrides({"lesions[2].material.k_c": 1.0})
    with pytest.raises(cariesim.Error, match=r"expected a field name"):
        scene.with_overrides({"lesions..k_c": 1.0})
    with pytest.raises(cariesim.Error, match=r"no such scene file, and not a built-in scene"):
        cariesim.load_scene("no-such-scene")


def test_params_follow_the_sliders_rules():
    model = cariesim.load_scene("friction-block").build()
    sim = cariesim.Simulator(model)
    assert sim.rate == model.servo_rate
    sim.params.set(0, "mu_s", 0.6)
    assert sim.params.get(0, "mu_s") == 0.6
    with pytest.raises(cariesim.Error, match=r"mu_s = -0.5 refused: mu_s"):
        sim.params.set(0, "mu_s", -0.5)
    assert sim.params.get(0, "mu_s") == 0.6  # unchanged
    with pytest.raises(cariesim.Error, match=r"unknown field 'friction'"):
        sim.params.set(0, "friction", 0.1)
    with pytest.raises(cariesim.Error, match=r"no lesion 3"):
        sim.params.get(3, "k_c")
    assert model.defaults.get(0, "mu_s") == 0.5  # the model's own are the scene's


def test_model_arrays_and_progress():
    stages = []
    model = cariesim.load_scene("friction-block").build(progress=lambda stage, f: stages.append((stage, f)))
    trees = model.trees()
    assert len(trees) >= 2  # the block's healthy part and its carious top
    assert [t["name"] for t in trees] == [p["name"] for p in model.parts]
    for t in trees:
        n = t["radii"].shape[0]
        assert n > 0 and t["centres"].shape == (n, 3) and t["material"].shape == (n,)
        assert (t["radii"] > 0).all()
    assert all(0.0 <= f <= 1.0 for _, f in stages)


def test_scenes_pickle():
    scene = cariesim.load_scene("friction-block", {"lesions[0].material.mu_s": 0.3})
    copy = pickle.loads(pickle.dumps(scene))
    assert copy.overrides == scene.overrides and copy.source_hash == scene.source_hash


def test_the_measured_surface_deviation_is_the_tree_commands(cariesim_exe):
    """model.parts with measure_deviation=True: per part the deviation of the tree from the surface
    (mm), the numbers `cariesim tree --json` reports for the same scene; none without asking."""
    import json

    from conftest import run_cariesim

    parts = cariesim.load_scene("friction-block").build(measure_deviation=True).parts
    tree = json.loads(run_cariesim(cariesim_exe, "tree", "friction-block", "--json").stdout)
    by_name = {p["name"]: p["deviation_mm"] for p in tree["parts"]}
    assert [p["name"] for p in parts] == list(by_name)
    for part in parts:
        theirs = by_name[part["name"]]
        assert 0.0 <= part["deviation_p50"] <= part["deviation_p95"] <= part["deviation_max"]
        for key in ("p50", "p95", "max"):
            assert part["deviation_" + key] == pytest.approx(theirs[key], rel=1e-6), (part["name"], key)
    assert "deviation_p50" not in cariesim.load_scene("friction-block").build().parts[0]
