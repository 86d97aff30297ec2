"""PLACEHOLDER on the replay branch: the range branch provides the real module (RangeSample)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class RangeSample:
    final_position: np.ndarray
    stopped: np.ndarray
    backscattered: np.ndarray
    transmitted: np.ndarray
    exit_energy: np.ndarray
    deposited: np.ndarray
