"""Scenario config: YAML loading, typed dotted overrides, closest-match error messages."""

import dataclasses
import math

import pytest

from simcalib.config import (ConfigError, PairingConfig, ScenarioConfig, apply_overrides,
                             build, describe_keys, leaf_paths, list_scenarios, load_config,
                             resolve_key, to_dict)


def test_every_scenario_file_loads():
    names = list_scenarios()
    for required in ("random", "line", "circle"):
        assert required in names
    for name, desc in names.items():
        assert desc and not desc.startswith("(unreadable"), name
        cfg = load_config(name)
        assert cfg.scenario == name
        assert isinstance(cfg, ScenarioConfig)
        assert len(cfg.solvers) >= 2


def test_typed_overrides():
    cfg = load_config("random", ["seed=3", "output=runs/x", "noise.sigma_r_deg=1.0",
                                 "solvers=[dqopt,daniilidis]", "source=noisy", "alpha=0.5",
                                 "pairing.step=2", "progress=false", "pairing.max_rotation_deg=5",
                                 "synthetic.line_length_m=3e0"])
    assert cfg.seed == 3 and isinstance(cfg.seed, int)
    assert cfg.output == "runs/x"
    assert cfg.noise.sigma_r_deg == 1.0
    assert cfg.solvers == ("dqopt", "daniilidis")
    assert cfg.alpha == 0.5 and cfg.alphas == (0.5,)
    assert cfg.pairing.step == 2
    assert cfg.progress is False
    assert cfg.pairing.max_rotation_deg == 5.0 and isinstance(cfg.pairing.max_rotation_deg, float)
    assert cfg.synthetic.line_length_m == 3.0
    # the synthetic generator's noise follows noise.* (one place for noise)
    assert math.isclose(cfg.synthetic.sigma_r_rad, math.radians(1.0))


def test_alpha_sweep_and_scalar_list_forms():
    cfg = load_config("random", ["alpha=[0.1,1,10]", "solvers=dqopt"])
    assert cfg.alphas == (0.1, 1.0, 10.0) and cfg.is_sweep
    assert cfg.solvers == ("dqopt",)  # a scalar for a list field is a one-element list


def test_suffix_keys_resolve_uniquely():
    assert resolve_key(ScenarioConfig, "sigma_r_deg") == "noise.sigma_r_deg"
    assert resolve_key(ScenarioConfig, "pairing.step") == "pairing.step"
    assert resolve_key(ScenarioConfig, "max_translation_m") == "pairing.max_translation_m"


def test_unknown_key_names_closest_match_and_valid_keys():
    with pytest.raises(ConfigError) as e:
        load_config("random", ["noise.sigma_r_dg=1"])
    msg = str(e.value)
    assert "noise.sigma_r_dg" in msg and "did you mean 'noise.sigma_r_deg'" in msg
    with pytest.raises(ConfigError) as e:
        load_config("random", ["sed=3"])
    assert "did you mean 'seed'" in str(e.value) and "valid top-level keys" in str(e.value)


def test_unknown_key_in_yaml_mapping():
    with pytest.raises(ConfigError) as e:
        load_config({"kind": "synthetic", "source": "noisy", "pairing": {"stpe": 2}})
    msg = str(e.value)
    assert "pairing.stpe" in msg and "pairing.step" in msg and "valid keys" in msg


@pytest.mark.parametrize("override, fragment", [
    ("seed=abc", "seed must be an integer; received 'abc'"),
    ("seed=1.5", "seed must be an integer; received 1.5"),
    ("seed=-1", "seed must be an integer >= 0; received -1"),
    ("alpha=-1", "alpha must be finite and > 0; received -1.0"),
    ("alpha=[1,x]", "alpha"),
    ("progress=maybe", "progress must be a boolean (true or false); received 'maybe'"),
    ("source=arcuo", "did you mean 'aruco'"),
    ("pairing.mode=sequential", "allowed: consecutive, random"),
    ("pairing.step=0", "pairing.step must be an integer >= 1; received 0"),
    ("solvers=[dqopt,danilidis]", "did you mean 'daniilidis'"),
    ("noise.sigma_t_m=nan", "not NaN"),
    ("noise=3", "is a section"),
    ("recording.jpeg_quality=101", "recording.jpeg_quality must be an integer in [1, 100]"),
])
def test_bad_values_fail_with_clear_message(override, fragment):
    with pytest.raises(ConfigError) as e:
        load_config("random", [override])
    assert fragment in str(e.value), str(e.value)


def test_unknown_scenario_lists_available():
    with pytest.raises(ConfigError) as e:
        load_config("circel")
    msg = str(e.value)
    assert "did you mean 'circle'" in msg and "random" in msg and "line" in msg


def test_source_aruco_needs_sim_world():
    with pytest.raises(ConfigError, match="source=aruco needs a simulated world"):
        load_config("random", ["source=aruco"])


def test_synthetic_noise_conflict_is_reported():
    with pytest.raises(ConfigError, match="conflicts with noise"):
        load_config("random", ["synthetic.sigma_r_rad=0.5"])


def test_prior_method_must_support_prior():
    with pytest.raises(ConfigError, match="cannot use a prior"):
        load_config("circle", ["prior.methods=[daniilidis]"])


def test_round_trip_through_dict():
    cfg = load_config("circle", ["alpha=[0.5,2]", "seed=7"])
    again = build(ScenarioConfig, to_dict(cfg))
    assert again == cfg


def test_overrides_do_not_mutate_input_and_generic_build():
    data = {"pairing": {"step": 3}}
    out = apply_overrides(data, ["pairing.step=4"])
    assert data == {"pairing": {"step": 3}} and out["pairing"]["step"] == 4
    p = build(PairingConfig, {"mode": "random", "n_pairs": 50})
    assert p.mode == "random" and p.n_pairs == 50 and p.step == 1
    assert dataclasses.is_dataclass(p)


def test_help_lists_every_leaf_key():
    lines = describe_keys()
    paths = leaf_paths(ScenarioConfig)
    assert len(lines) == len(paths)
    text = "\n".join(lines)
    for key in ("noise.sigma_r_deg", "pairing.max_time_diff_s", "prior.a", "seed"):
        assert key in text
