from dataclasses import dataclass

import pytest

from tognet.config import Config, ConfigError, doc


@dataclass(frozen=True)
class Inner(Config):
    sigma: float = doc(0.001, "Noise std-dev (m).")


@dataclass(frozen=True)
class Outer(Config):
    count: int = doc(3, "How many.")
    name: str = doc("x", "A name.")
    inner: Inner = doc(factory=Inner, text="Nested config.")
    bounds: tuple[float, float] = doc((0.0, 1.0), "A range.")


def test_round_trip(tmp_path):
    cfg = Outer(count=5, inner=Inner(sigma=0.2), bounds=(1.0, 2.0))
    path = cfg.save(tmp_path / "c.json")
    assert Outer.load(path) == cfg


def test_typo_names_key_and_suggests():
    with pytest.raises(ConfigError, match="unknown key 'cuont'.*did you mean 'count'"):
        Outer.from_dict({"cuont": 3})


def test_nested_typo_and_wrong_type():
    with pytest.raises(ConfigError, match=r"Outer\.inner: unknown key 'sigam'"):
        Outer.from_dict({"inner": {"sigam": 1.0}})
    with pytest.raises(ConfigError, match=r"Outer\.count: expected an integer"):
        Outer.from_dict({"count": "three"})


def test_wrong_class_and_bad_json(tmp_path):
    path = Inner().save(tmp_path / "inner.json")
    with pytest.raises(ConfigError, match="holds a Inner"):
        Outer.load(path)
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ConfigError, match="not valid JSON"):
        Outer.load(bad)


def test_every_field_described():
    assert all(text for _, _, text in Outer.describe())
