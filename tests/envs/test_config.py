"""EnvConfig: one-line errors on bad values; the YAML under conf/ equals the dataclass defaults."""

import dataclasses
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

import formation_rl.apps.demo  # noqa: F401  (registers the rollout schema)
from formation_rl.envs import EnvConfig, FormationConfig, FormationEnv
from formation_rl.envs.config import RewardConfig

CONF = str(Path(__file__).resolve().parents[2] / "formation_rl" / "conf")


def compose_env(*overrides):
    with initialize_config_dir(config_dir=CONF, version_base=None):
        return compose(config_name="rollout", overrides=list(overrides)).env


def test_the_world_defaults_come_from_the_schema_alone():
    assert EnvConfig.from_dict(compose_env()) == EnvConfig()
    # one source of truth: conf/env/default.yaml writes no value, the schema (EnvConfig) holds them all
    assert not OmegaConf.load(Path(CONF) / "env" / "default.yaml")


def test_formation_and_reward_groups():
    cfg = EnvConfig.from_dict(compose_env("formation=chain", "reward=fixed"))
    assert cfg.formation == FormationConfig(shape="chain", spacing=0.4)
    assert cfg.reward.variant == "fixed" and cfg.area_formation == cfg.formation
    cfg = EnvConfig.from_dict(compose_env("env.num_robots=7", "env.formation.angle_deg=30"))
    assert cfg.num_robots == 7 and cfg.formation.angle_deg == 30.0
    assert cfg.area_formation == FormationConfig(shape="chain", spacing=0.4)


def test_hydra_rejects_misspelt_key_and_wrong_type():
    with pytest.raises(Exception, match="env.num_robot"):
        compose_env("env.num_robot=3")
    with pytest.raises(ValueError, match="env.num_robot: unknown field"):  # forced in with '+'
        EnvConfig.from_dict(compose_env("+env.num_robot=3"))
    with pytest.raises(Exception, match="num_robots"):
        compose_env("env.num_robots=five")
    with pytest.raises(Exception, match="reward"):
        compose_env("reward=curvy")


BAD = [
    ({"relative_positions": "yes"}, "env.relative_positions = 'yes'", "true or false"),
    ({"num_robots": 1}, "env.num_robots = 1", "integer >= 2"),
    ({"num_obstacles": -1}, "env.num_obstacles = -1", ">= 0"),
    ({"dt": 0.0}, "env.dt = 0.0", "> 0"),
    ({"max_speed": -0.85}, "env.max_speed = -0.85", "> 0"),
    ({"max_force": float("nan")}, "env.max_force = nan", "finite"),
    ({"obstacle_radius_min": -0.4}, "env.obstacle_radius_min = -0.4", "> 0"),
    ({"obstacle_radius_max": 0.3}, "env.obstacle_radius_max = 0.3", ">= obstacle_radius_min"),
    ({"obstacle_area_x": (3.0, -3.0)}, "env.obstacle_area_x", "low < high"),
    ({"goal_low": 3.6}, "env.goal_low = 3.6", "low <= goal_high"),
    ({"start_high": 5.0}, "env.start_low", "inside the arena"),
    ({"sensing_range": -0.2}, "env.sensing_range = -0.2", ">= 0"),
    ({"max_steps": 0}, "env.max_steps = 0", ">= 1"),
    ({"formation": FormationConfig(shape="star")}, "env.formation.shape = 'star'", "v, chain"),
    ({"formation": FormationConfig(spacing=0.0)}, "env.formation.spacing = 0.0", "> 0"),
    ({"reward": RewardConfig(variant="mixed")}, "env.reward.variant = 'mixed'", "hybrid, fixed"),
    ({"reward": RewardConfig(tolerance=-1.0)}, "env.reward.tolerance = -1.0", ">= 0"),
    ({"num_obstacles": 30}, "env.num_obstacles = 30", "cannot be placed"),
    ({"num_robots": 17}, "env.num_robots = 17", "enlarge the start square"),
]


@pytest.mark.parametrize("fields,names,allowed", BAD, ids=[f"{next(iter(f))}-{i}" for i, (f, _, _) in enumerate(BAD)])
def test_bad_config_raises_one_line_value_error(fields, names, allowed):
    with pytest.raises(ValueError) as err:
        FormationEnv(2, config=dataclasses.replace(EnvConfig(), **fields))
    msg = str(err.value)
    assert "\n" not in msg
    assert names in msg and allowed in msg


def test_unknown_field_and_bad_num_envs():
    with pytest.raises(ValueError, match=r"env.num_robot: unknown field; allowed: .*num_robots"):
        FormationEnv(1, config={"num_robot": 3})
    with pytest.raises(ValueError, match=r"num_envs = 0 is invalid: must be an integer >= 1"):
        FormationEnv(0)


def test_removed_fields_load_at_their_off_value_and_name_their_commit_otherwise():
    """A checkpoint of an earlier version names fields removed since (formation_rl.utils.RETIRED): at their off value
    they are dropped, so the policy loads; at another value the one-line error names the commit that has the option."""
    old = dataclasses.asdict(EnvConfig())
    old["sort_obstacles"] = False
    old["reward"] = dict(old["reward"], leader_speed_cost=0.0, leader_speed_limit=0.75, leader_speed_floor=0.0)
    assert EnvConfig.from_dict(old) == EnvConfig()
    old["reward"]["leader_speed_cost"] = 10.0
    with pytest.raises(ValueError, match=r"^env.reward.leader_speed_cost = 10.0: this option was removed .* 415502c"):
        EnvConfig.from_dict(old)


def test_config_dict_and_omegaconf_equivalent():
    node = OmegaConf.create({"num_robots": 3, "formation": {"shape": "chain", "spacing": 0.3}})
    plain = {"num_robots": 3, "formation": {"shape": "chain", "spacing": 0.3}}
    assert EnvConfig.from_dict(node) == EnvConfig.from_dict(plain)
    assert FormationEnv(1, config=node).config.obs_dim == 4 + 4 + 12 + 1
