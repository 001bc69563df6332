"""The Franka Panda executes imagined interactions in MuJoCo, with impedance control and force limits."""

from __future__ import annotations

from rail_mj.llm.schemas import Request
from rail_mj.robot.control import RobotConfig
from rail_mj.robot.executor import (
    DriveResult,
    ExecutionResult,
    ForceEvent,
    ScoringFunction,
    drive,
    execute,
)
from rail_mj.robot.judge import EndState, Judgement, judge
from rail_mj.robot.model import fetch_panda, load_panda_spec, panda_dir
from rail_mj.robot.request import parse_request
from rail_mj.robot.run import ObjectSpec, run_request
from rail_mj.robot.scene import build_robot_scene

__all__ = [
    "RobotConfig",
    "ExecutionResult",
    "ForceEvent",
    "DriveResult",
    "ScoringFunction",
    "build_robot_scene",
    "drive",
    "execute",
    "fetch_panda",
    "load_panda_spec",
    "panda_dir",
    "Request",
    "parse_request",
    "ObjectSpec",
    "run_request",
    "EndState",
    "Judgement",
    "judge",
]
