"""Closed-loop balance from the IMU, on top of the gait's joint targets.

- Ankle strategy: the trunk's measured tilt and tilt rate move the ankles so the feet push the body back
  upright: pitch errors act on the ankle pitch joints, roll errors on the ankle roll joints.
- Swing-leg levelling: the swing leg is turned at the hip by the trunk's measured pitch, so the foot lands where
  the plan put it in the world even while the body rocks. Without it the body rocked back ~3 degrees in each
  single support and every step landed short: forward walking covered half the commanded distance.
- Stance-leg levelling: the leg on the floor is turned at the hip (roll and pitch) against the trunk's measured
  tilt, so the trunk stays upright over the foot that carries it. Without it the trunk sagged towards the swinging
  leg in every single support, 12 degrees peak to peak, and the hand on the low side brushed the floor; with it
  the sag is about 2 degrees (docs/design/walking.md, "Stance-leg levelling"). Only with the arms at rest (the
  standing posture's): it was tuned so, and with an arm held out carrying something it shook the hand.

Signs come from each joint's axis in the model (a mirrored sign makes the robot fall), so left and right legs
get the same physical correction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from robot.control.clamp import clamp
from robot.model import humanoid_v1

# Gains measured in the walking prototype (shared FINDINGS.md): 0.3 x tilt + 0.02 x tilt rate.
TILT_GAIN = 0.3
RATE_GAIN = 0.02
MAX_CORRECTION_RAD = 0.25
# Swing-leg levelling gain (1.0 = the full measured pitch): forward tracking error 51% -> 15% open loop.
SWING_LEVELLING_GAIN = 1.0
MAX_LEVELLING_RAD = 0.15
# Stance-leg levelling gains (rad of hip per rad of trunk tilt), chosen on open-floor walks (scripts 0-19) and checked
# on others (100-139). Roll below 1.5 left a sway of 7-9 degrees; roll alone made sideways walks drift back (9 cm in
# 0.3 m), which the pitch term takes back; pitch 0.7 or roll 2.5 start a rocking of 6-8 degrees when turning in place.
STANCE_ROLL_GAIN = 2.0
STANCE_PITCH_GAIN = 0.6
MAX_STANCE_LEVELLING_RAD = 0.2


@dataclass(frozen=True)
class TrunkTilt:
    roll: float
    pitch: float

    @staticmethod
    def from_quat(quat_wxyz: np.ndarray) -> TrunkTilt:
        w, x, y, z = (float(v) for v in quat_wxyz)
        roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
        pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
        return TrunkTilt(roll, pitch)


class AnkleBalance:
    def __init__(self, joint_axes: dict[str, np.ndarray], tilt_gain: float = TILT_GAIN, rate_gain: float = RATE_GAIN):
        names = humanoid_v1.JOINT_NAMES
        self._pitch_idx = [names.index(n) for n in ("l_ank_pitch", "r_ank_pitch")]
        self._roll_idx = [names.index(n) for n in ("l_ank_roll", "r_ank_roll")]
        # Joint axes are expressed in their links; with the feet flat these match the trunk frame closely enough.
        self._pitch_sign = np.array([float(np.sign(joint_axes[n][1])) for n in ("l_ank_pitch", "r_ank_pitch")])
        # Roll acts with the opposite sign to pitch: found by experiment (standing roll drifted 5 deg the other way).
        self._roll_sign = -np.array([float(np.sign(joint_axes[n][0])) for n in ("l_ank_roll", "r_ank_roll")])
        self.tilt_gain = tilt_gain
        self.rate_gain = rate_gain

        self._hip_pitch_idx = {s: names.index(f"{s[0]}_hip_pitch") for s in ("left", "right")}
        self._hip_pitch_sign = {s: float(np.sign(joint_axes[f"{s[0]}_hip_pitch"][1])) for s in ("left", "right")}
        self.swing_gain = SWING_LEVELLING_GAIN
        self._hip_roll_idx = {s: names.index(f"{s[0]}_hip_roll") for s in ("left", "right")}
        self._hip_roll_sign = {s: float(np.sign(joint_axes[f"{s[0]}_hip_roll"][0])) for s in ("left", "right")}
        self.stance_roll_gain = STANCE_ROLL_GAIN
        self.stance_pitch_gain = STANCE_PITCH_GAIN

    def correct(
        self,
        targets: np.ndarray,
        quat_wxyz: np.ndarray,
        gyro: np.ndarray,
        swing_leg: str | None = None,
        level_stance: bool = True,
    ) -> np.ndarray:
        """Targets with the ankle correction (and, while a leg swings, both legs' levelling) added; a new array.
        `level_stance` False leaves the supporting leg to the ankles (the arms not at rest: see
        `WholeBodyIK.arms_at_rest`).
        Without an IMU reading (NaN: a real robot's IMU missed a tick) there is nothing to correct by: unchanged."""
        if not (np.isfinite(quat_wxyz).all() and np.isfinite(gyro).all()):
            return np.array(targets, dtype=float)
        tilt = TrunkTilt.from_quat(quat_wxyz)
        pitch = self.tilt_gain * tilt.pitch + self.rate_gain * float(gyro[1])
        roll = self.tilt_gain * tilt.roll + self.rate_gain * float(gyro[0])
        out = np.array(targets, dtype=float)
        out[self._pitch_idx] += clamp(pitch, -MAX_CORRECTION_RAD, MAX_CORRECTION_RAD) * self._pitch_sign
        out[self._roll_idx] += clamp(roll, -MAX_CORRECTION_RAD, MAX_CORRECTION_RAD) * self._roll_sign
        if swing_leg is not None:
            # turn the whole leg against the trunk's pitch: the foot keeps its planned world placement and stays flat
            level = clamp(self.swing_gain * tilt.pitch, -MAX_LEVELLING_RAD, MAX_LEVELLING_RAD)
            out[self._hip_pitch_idx[swing_leg]] -= level * self._hip_pitch_sign[swing_leg]
            if level_stance:
                self._level_stance(out, tilt, "left" if swing_leg == "right" else "right")
        return out

    def _level_stance(self, out: np.ndarray, tilt: TrunkTilt, stance: str) -> None:
        """Turn the supporting leg at the hip so the trunk above it comes back upright (in place, on `out`)."""
        limit = MAX_STANCE_LEVELLING_RAD
        roll = clamp(self.stance_roll_gain * tilt.roll, -limit, limit)
        pitch = clamp(self.stance_pitch_gain * tilt.pitch, -limit, limit)
        out[self._hip_roll_idx[stance]] += roll * self._hip_roll_sign[stance]
        out[self._hip_pitch_idx[stance]] -= pitch * self._hip_pitch_sign[stance]
