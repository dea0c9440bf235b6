"""Config hashing: stable, order-independent, sensitive to every field."""

from dataclasses import dataclass

import numpy as np
import pytest

from navbench.config import canonical_json, config_hash


@dataclass(frozen=True)
class _Cfg:
    steps: int = 10
    lr: float = 0.05
    name: str = "x"
    shape: tuple = (2, 3)


def test_hash_is_deterministic_and_sorted():
    assert config_hash({"b": 1, "a": 2}) == config_hash({"a": 2, "b": 1})
    assert canonical_json(_Cfg()) == '{"lr":0.05,"name":"x","shape":[2,3],"steps":10}'
    assert len(config_hash(_Cfg())) == 64


def test_hash_changes_with_any_field():
    base = config_hash(_Cfg())
    assert config_hash(_Cfg(steps=11)) != base
    assert config_hash(_Cfg(lr=0.05 + 1e-16 * 8)) != base
    assert config_hash(_Cfg(shape=(3, 2))) != base


def test_numpy_scalars_and_bad_types():
    assert config_hash({"a": np.float64(1.5)}) == config_hash({"a": 1.5})
    with pytest.raises(TypeError):
        config_hash({"a": object()})
    with pytest.raises(ValueError):
        config_hash({"a": float("nan")})
