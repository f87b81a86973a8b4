"""The opt-in ``wide`` generator profile and part variants; the default generator left byte for byte alone.

The reference digests below (the first 128 bits of each file's SHA-256) are of the files the default
config made on the main branch before part variants existed (2026-12-06, commit ddc937a: 3 PG-Primitive
and 3 PG-Complex objects of each split): the README's test sets must not change when the generator grows
new options.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tognet.cli import app
from tognet.collect.config import PipelineConfig, load_preset
from tognet.config import ConfigError
from tognet.objects import load_catalog
from tognet.objects.compose import PartVariant, ShapeRanges, sample_layout, vary_part
from tognet.objects.generate import (
    CONFIG_NAME,
    GeneratorConfig,
    generate_set,
    load_generator_config,
)
from tognet.objects.stats import object_stats

REFERENCE = """
complex-test/catalog.csv 381e92c2bb17883f4e16bc159ea0d5f7
complex-test/catalog.json 3529a95c127daa634e52aee0c0587892
complex-test/complex-test-000000/collision_00.obj a9a5ba142b21c757b71113febfa46bce
complex-test/complex-test-000000/collision_01.obj 748a296ec28d80a4f4247efa1cf440fb
complex-test/complex-test-000000/object.xml c8549b021a87a74b52fddae6cd52814b
complex-test/complex-test-000000/visual.obj 08cdf93805fdacbfdf61188f30abcb45
complex-test/complex-test-000001/collision_00.obj 4b9160c665e679e3c438a6ff274358ed
complex-test/complex-test-000001/collision_01.obj 5177cd8dcd378cf26d0ebce8e2f89932
complex-test/complex-test-000001/object.xml 8912a89bb263a4f4dce88994c1388920
complex-test/complex-test-000001/visual.obj 2fbe58857982754bf61eb10720d4d7a6
complex-test/complex-test-000002/collision_00.obj 694bb65e539922f293be0c74532f6af8
complex-test/complex-test-000002/collision_01.obj dc6a56a3e03be0e9f9c437c08c9d79c5
complex-test/complex-test-000002/object.xml eff7e317fdfaebb700beeb98c89aadd3
complex-test/complex-test-000002/visual.obj 59fc4cf0ccdd91ee93b0c835ae0e20e3
complex-test/generator_config.json 41fb6ecbeca5d65c296db9c77f55a9b5
complex-train/catalog.csv 4dbc702e5dc736cee0301b736a617c50
complex-train/catalog.json 0208a0563975c2139b5e82ac569138a8
complex-train/complex-train-000000/collision_00.obj daca9d08aa9416579a1426d1babe1c34
complex-train/complex-train-000000/collision_01.obj e351d55e8febd1aa1d856af5fb7da5dd
complex-train/complex-train-000000/object.xml d3a7f72d888d4ae54d2c82f829306238
complex-train/complex-train-000000/visual.obj f4ec8b7a0b1c4c06f95b82aae3b28309
complex-train/complex-train-000001/collision_00.obj 013a6e40837a40bb198b882a159e4d60
complex-train/complex-train-000001/collision_01.obj 559b08ad7372ae8fb4c3f624ed604419
complex-train/complex-train-000001/object.xml 38fa723e380769157a2e3913ae94b61d
complex-train/complex-train-000001/visual.obj 95aa0d5f516882a670d03aa0ecce3c9c
complex-train/complex-train-000002/collision_00.obj 8a57f7f27cfc0c57a4854b96fd7310bd
complex-train/complex-train-000002/collision_01.obj a199f9eb18bbea7a9e309099bd764c38
complex-train/complex-train-000002/object.xml 096d9cdf9ceae2802bfc58aa8646ba13
complex-train/complex-train-000002/visual.obj e0d5078a1141046b3efcef9979ecbe6c
complex-train/generator_config.json 41fb6ecbeca5d65c296db9c77f55a9b5
primitive-test/catalog.csv 59cfcdeebdfddf539d7186465a80cdfe
primitive-test/catalog.json 604ee33441f96f80e6df6901585f3da1
primitive-test/generator_config.json 41fb6ecbeca5d65c296db9c77f55a9b5
primitive-test/primitive-test-000000/collision_00.obj c9989852c9d8bd94288aa3776904c1ce
primitive-test/primitive-test-000000/collision_01.obj 64ab487019747092364267d6778ff6e1
primitive-test/primitive-test-000000/object.xml 7d8bb28d5fe14275374022860ea61719
primitive-test/primitive-test-000000/visual.obj de8ea418ea5a300028cc99b09a578645
primitive-test/primitive-test-000001/collision_00.obj 5a84c3651cdaeeb8003f0496facf4c34
primitive-test/primitive-test-000001/collision_01.obj 8a4d22ae849524fd096f123af0833ab7
primitive-test/primitive-test-000001/object.xml d72b92a63b74ab6d8dacf3b3be994124
primitive-test/primitive-test-000001/visual.obj f7b56188cd06ab0e00b04e63d833ccbc
primitive-test/primitive-test-000002/collision_00.obj 7258e272e406bfb8a4ce043312b81fed
primitive-test/primitive-test-000002/collision_01.obj b8fb268f49a5d48fb0f825bc7f444123
primitive-test/primitive-test-000002/object.xml b3ed178ca3cd70a8f38a25725a0d05cc
primitive-test/primitive-test-000002/visual.obj feb34961ac9b02751dff7b2710cfd59e
primitive-train/catalog.csv f6b90576282fb8fd717dd6c2370762e5
primitive-train/catalog.json ef25186454d4057fb74be458e363f4a0
primitive-train/generator_config.json 41fb6ecbeca5d65c296db9c77f55a9b5
primitive-train/primitive-train-000000/collision_00.obj 85d4fcd3c5d838f5548c3969b38b67d7
primitive-train/primitive-train-000000/collision_01.obj ff3e3eb36357b9d45e003073b91a2e05
primitive-train/primitive-train-000000/object.xml bf9b412601d06a57baf2a57f841a67e2
primitive-train/primitive-train-000000/visual.obj 7ff98327c107dc44f2c8f99259f16a8a
primitive-train/primitive-train-000001/collision_00.obj 158b8c935a3e67095590f2828b00c975
primitive-train/primitive-train-000001/collision_01.obj a5abe89218dd5034335b9766ab91d4bd
primitive-train/primitive-train-000001/object.xml deeea9ff14e91c8cf6848a86b4438e72
primitive-train/primitive-train-000001/visual.obj da6b1b8da299528f78ac5cbdc709264e
primitive-train/primitive-train-000002/collision_00.obj 5d2d416e569db92eed3b638df86581b6
primitive-train/primitive-train-000002/collision_01.obj b4b00bd03630ae0b8bc7909e652c5a3d
primitive-train/primitive-train-000002/object.xml 03368defb389a342dbe9f020ccc11bc4
primitive-train/primitive-train-000002/visual.obj c11202c66cdfb0a16d1c04e4c6321a83
"""


def _digests(root: Path) -> dict[str, str]:
    return {p.relative_to(root).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()[:32]
            for p in sorted(root.rglob("*")) if p.is_file()}


def test_the_default_generator_makes_the_same_files_as_before_part_variants(tmp_path):
    for kind in ("primitive", "complex"):
        for split in ("train", "test"):
            generate_set(kind, split, 3, tmp_path / f"{kind}-{split}")
    expected = dict(line.split() for line in REFERENCE.strip().splitlines())
    got = _digests(tmp_path)
    assert sorted(got) == sorted(expected)
    changed = [name for name in expected if got[name] != expected[name]]
    assert not changed, f"the default generator changed these files: {changed}"


def test_no_variant_draws_no_random_number():
    rng = np.random.default_rng(3)
    sizes = (0.2, 0.03, 0.02)
    info: dict = {}
    never = ShapeRanges(variants=(PartVariant(name="flat", part="B", probability=0.0, height=(0.003, 0.01)),
                                  PartVariant(name="t-only", part="A", probability=1.0, rules=("T",),
                                              height=(0.003, 0.01))))
    for ranges, part, rule in ((ShapeRanges(), "A", "T"), (never, "B", "T"), (never, "A", "L")):
        state = rng.bit_generator.state
        assert vary_part(rng, ranges, part, rule, sizes, info) == sizes
        assert rng.bit_generator.state == state and info == {}
    flat = vary_part(rng, never, "A", "T", sizes, info)
    assert flat[:2] == sizes[:2] and 0.003 <= flat[2] <= 0.01 and info == {"variants": {"A": "t-only"}}


def test_variant_settings_are_checked():
    with pytest.raises(ConfigError, match="add up to 1.2"):
        ShapeRanges(variants=(PartVariant(part="A", probability=0.6), PartVariant(part="A", probability=0.6)))
    with pytest.raises(ConfigError, match="unknown rules"):
        PartVariant(rules=("T", "Y"))
    with pytest.raises(ConfigError, match="low <= high"):
        PartVariant(height=(0.02, 0.01))
    with pytest.raises(ConfigError, match="unknown generator profile 'wider'"):
        load_generator_config("wider")
    assert load_generator_config("default") == GeneratorConfig()
    assert "variants" not in GeneratorConfig().to_dict()["primitive"]["ranges"]  # default files unchanged


def _sizes_in(variant: PartVariant, extents: list[float]) -> bool:
    ranges = (variant.length, variant.width, variant.height)
    return all(bounds is None or bounds[0] - 1e-9 <= value <= bounds[1] + 1e-9
               for bounds, value in zip(ranges, extents, strict=True))


def test_wide_layouts_draw_every_variant_inside_its_ranges():
    ranges = load_generator_config("wide").primitive.ranges
    by_name = {v.name: v for v in ranges.variants}
    seen = set()
    rng = np.random.default_rng(0)
    for i in range(300):
        rule = "TLX"[i % 3]
        layout = sample_layout(rng, ranges, rule)
        for part, extents in (("A", layout.extents_a), ("B", layout.extents_b)):
            name = layout.info["variants"].get(part, "")
            if name:
                seen.add(name)
                assert rule in by_name[name].rules and _sizes_in(by_name[name], list(extents))
    assert seen == set(by_name)


def test_wide_objects_lie_in_the_widened_ranges(tmp_path):
    wide = load_generator_config("wide")
    ranges = wide.primitive.ranges
    records = generate_set("primitive", "train", 24, tmp_path / "p", config=wide)
    records += generate_set("complex", "train", 2, tmp_path / "c", config=wide)
    assert GeneratorConfig.load(tmp_path / "p" / CONFIG_NAME) == wide
    stats = [object_stats(r) for r in records]
    assert all(ranges.friction[0] <= s.friction <= ranges.friction[1] for s in stats)
    assert all(ranges.light_density[0] - 1e-6 <= rho <= ranges.metal_density[1] + 1e-6
               for r in records for rho in r.extra["part_densities"])
    # beyond what the default generator makes (narrowest part >= 1.5 cm, height 1.5-4 cm, length >= 15 cm)
    assert min(s.narrowest for s in stats) < 0.012
    assert min(s.height for s in stats) < 0.015 and max(s.height for s in stats) > 0.05
    assert min(s.friction for s in stats) < 0.5
    for r, s in zip(records, stats, strict=True):
        names = r.extra["variants"]
        if names.get("A") == "thin-shaft":  # the thin part is in the collision pieces, not only the layout
            assert s.narrowest <= 0.012 + 1e-6
        if names.get("A") in ("thin-shaft", "flat-handle") and names.get("B") == "flat-blade":
            assert s.height <= 0.015 + 1e-6
    assert np.mean([s.rests_flat for s in stats]) >= 0.9


def test_generate_with_the_wide_profile_by_name(tmp_path):
    runner = CliRunner()
    base = ["objects", "generate", "--kind", "primitive", "--count", "2"]
    result = runner.invoke(app, [*base, "--out", str(tmp_path / "w"), "--config", "wide"])
    assert result.exit_code == 0, result.output
    assert GeneratorConfig.load(tmp_path / "w" / CONFIG_NAME) == load_generator_config("wide")
    assert all("variants" in r.extra for r in load_catalog(tmp_path / "w"))
    result = runner.invoke(app, [*base, "--out", str(tmp_path / "x"), "--config", "wdie"])
    assert result.exit_code == 2 and "unknown generator profile 'wdie'" in result.output
    assert not (tmp_path / "x" / "catalog.json").exists()


def test_the_medium_wide_preset_is_medium_on_the_wide_generator(tmp_path):
    from tognet.collect.pipeline import make_objects

    medium, wide = load_preset("medium"), load_preset("medium-wide")
    assert wide.generator == load_generator_config("wide") and medium.generator is None
    assert wide == medium.replace(name="medium-wide", generator=wide.generator)
    assert "generator" not in medium.to_dict()  # the existing presets' run files stay as they were
    tiny = PipelineConfig(objects={"primitive": 2, "complex": 0}, generator=wide.generator)
    records = make_objects(tiny, tmp_path, 1, lambda _: None, False)
    assert len(records) == 2
    assert GeneratorConfig.load(tmp_path / "objects" / "primitive-train" / CONFIG_NAME) == wide.generator
