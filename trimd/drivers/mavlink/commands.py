"""What trimd sends to an ArduSub vehicle, and when (``docs/ardusub.md``).

:class:`Commander` is the vehicle policy of the MAVLink link. It runs in the link's I/O
thread (it owns the pymavlink ``MAVLink`` object there, so nothing else writes) and knows
nothing of sockets:

* (trimd's own HEARTBEAT, texts and values: :mod:`~trimd.drivers.mavlink.outbox`);
* (each COMMAND_LONG re-sent until answered: :mod:`~trimd.drivers.mavlink.requests`);
* when the vehicle appears (again): MAV_CMD_SET_MESSAGE_INTERVAL for each message in
  :data:`STREAMS`, one at a time; a refusal or no answer falls back to REQUEST_DATA_STREAM
  for that message's stream, with a warning; then, for the whole session, whenever
  ATTITUDE, SERVO_OUTPUT_RAW or the depth message arrives at less than 70 % of the rate
  asked (:mod:`~trimd.drivers.mavlink.rates`: another ground station's request won), the
  same request again, with one warning the first time; PARAM_REQUEST_READ for FRAME_CONFIG,
  SERVOn_FUNCTION and MOT_n_DIRECTION, and a warning for each disagreement with the profile;
* HoldAttitude: ALT_HOLD (MAV_CMD_DO_SET_MODE), then SET_ATTITUDE_TARGET with the body-rate
  and throttle-ignore bits (type_mask 71) at 4 Hz, with neutral MANUAL_CONTROL at 10 Hz
  only while trimd is the only ground station (:mod:`~trimd.drivers.mavlink.stations`):
  beside a pilot's station, that station keeps the sticks and ArduSub's pilot-input
  failsafe, and trimd sends no MANUAL_CONTROL at all;
* OpenLoop: MANUAL, then MANUAL_CONTROL with those axes at 10 Hz (refused beside another
  ground station);
* Release: one last SET_ATTITUDE_TARGET at level (roll = pitch = 0, the hold's heading),
  then stop both and restore the mode the operator had before trimd's first command.
  ArduSub keeps honouring the last target for 5 s in ALT_HOLD, so merely falling silent
  would leave the vehicle tilted for up to 5 s; the level target brings it back at once;
* Arm: MAV_CMD_COMPONENT_ARM_DISARM;
* link lost: stop commanding at once (a command must come again after a loss);
* someone else takes over while trimd commands (the vehicle leaves the mode trimd set
  without trimd asking, or another station's sticks leave neutral): stop commanding at
  once, without restoring any mode (the pilot chose it); :meth:`Commander.on_message`
  and :meth:`Commander.yield_control` return the words for a
  :class:`~trimd.core.samples.PilotInput`.

A command's future completes when the vehicle confirms (COMMAND_ACK accepted, or a
HEARTBEAT in the wanted mode) and fails with a LinkError on refusal or after 3 s.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from trimd.core.model import quaternion_from_euler
from trimd.core.profile import Profile
from trimd.core.samples import Arm, Command, HoldAttitude, OpenLoop, Release
from trimd.drivers.mavlink.ardusub import mode_number
from trimd.drivers.mavlink.decode import MavlinkDecoder
from trimd.drivers.mavlink.message import MavEncoder, MavMessage
from trimd.drivers.mavlink.rates import RateWatch
from trimd.drivers.mavlink.requests import (
    ACCEPTED,
    CommandRequests,
    fail,
    result_name,
    succeed,
)
from trimd.drivers.mavlink.stations import Stations
from trimd.drivers.mavlink.url import MavlinkOptions

__all__ = ["HOLD_PERIOD_S", "PILOT_PERIOD_S", "STREAMS", "Commander", "pilot_axes"]

log = logging.getLogger("trimd.drivers.mavlink.link")

#: message → (message id, rate [Hz], legacy REQUEST_DATA_STREAM stream id)
STREAMS: dict[str, tuple[int, float, int]] = {
    "ATTITUDE": (30, 10.0, 10), "SERVO_OUTPUT_RAW": (36, 10.0, 3), "SYS_STATUS": (1, 2.0, 2),
    "VFR_HUD": (74, 5.0, 11), "GLOBAL_POSITION_INT": (33, 5.0, 6),
    "SCALED_PRESSURE2": (137, 5.0, 1),
}
_DEPTH_MESSAGE = {"vfr_hud": "VFR_HUD", "global_position": "GLOBAL_POSITION_INT",
                  "pressure": "SCALED_PRESSURE2"}
HOLD_PERIOD_S = 0.25        # SET_ATTITUDE_TARGET at 4 Hz (ArduSub drops a target after 5 s)
PILOT_PERIOD_S = 0.1        # MANUAL_CONTROL at 10 Hz (pilot-input failsafe after 3 s)
_PARAM_WAIT_S = 3.0
_TYPE_MASK = 0b1000111      # ignore body roll/pitch/yaw rates and throttle
_NEUTRAL = (0, 0, 500, 0, 0, 0, 0)  # MANUAL_CONTROL x, y, z, r, s, t, enabled_extensions


def pilot_axes(axes: tuple[float, ...]) -> tuple[int, ...]:
    """MANUAL_CONTROL x, y, z, r, s (pitch), t (roll), enabled_extensions of OpenLoop axes
    (surge, sway, heave down, roll, pitch, yaw in [−1, 1]); z = 500 is neutral, up > 500.

    Examples
    --------
    >>> pilot_axes((0.5, 0, 1.0, 0, 0, -1))
    (500, 0, 0, -1000, 0, 0, 0)
    """
    surge, sway, heave, roll, pitch, yaw = (max(-1.0, min(1.0, a)) for a in axes)
    ext = 0b11 if roll or pitch else 0
    return (round(surge * 1000), round(sway * 1000), round(500 - heave * 500),
            round(yaw * 1000), round(pitch * 1000), round(roll * 1000), ext)


class Commander:
    """ArduSub command policy over one pymavlink ``MAVLink`` object (module docstring).

    ``warn`` receives each warning once (stream fallbacks, parameter disagreements,
    unanswered mode restores, which pilot-input case applies); ``stations`` are the other
    ground stations the link has seen.
    """

    def __init__(self, mav: MavEncoder, profile: Profile, decoder: MavlinkDecoder,
                 options: MavlinkOptions, warn: Callable[[str], None],
                 stations: Stations) -> None:
        self.mav = mav
        self.profile = profile
        self.decoder = decoder
        self.options = options
        self.warn = warn
        self.stations = stations
        self.target: tuple[float, float, float] | None = None
        self.pilot: tuple[int, ...] | None = None
        self._mode: str | None = None       # the mode the present command flies in
        self._mode_reached = False          # a heartbeat has shown it since
        self._restore: str | None = None
        self._requests = CommandRequests(mav, options.source[0])
        self._mode_wanted: tuple[str, Future[None] | None] | None = None
        self._streams: deque[str] = deque()
        self.rates = RateWatch()
        self._watched: set[str] = set()
        self._rates_warned = False
        self._params_wanted: set[str] = set()
        self._params_seen: set[str] = set()
        self._params_due = math.inf
        self._params_tries = 0
        self._due = {"target": -math.inf, "pilot": -math.inf}

    # ---------------------------------------------------------------- vehicle events
    def on_vehicle(self, now: float) -> None:
        """The vehicle's heartbeat appeared (first time or after a loss)."""
        depth = _DEPTH_MESSAGE[self.options.depth]
        self._streams = deque(n for n in STREAMS if n in (
            "ATTITUDE", "SERVO_OUTPUT_RAW", "SYS_STATUS", depth))
        self.rates, self._watched = RateWatch(), {"ATTITUDE", "SERVO_OUTPUT_RAW", depth}
        names = ["FRAME_CONFIG", *(f"SERVO{n}_FUNCTION" for n in range(1, 17)),
                 *(f"MOT_{t.channel}_DIRECTION" for t in self.profile.thrusters
                   if t.channel <= 12)]
        if self.options.depth == "pressure":
            names.append("BARO2_GND_PRESS")
        self._params_wanted, self._params_seen, self._params_tries = set(names), set(), 0
        self._request_params(names, now)
        if self.options.pilot == "always":
            self.pilot = self.pilot or _NEUTRAL

    def on_lost(self) -> None:
        """The vehicle's heartbeat stopped: stop commanding, fail what waits for it."""
        self.target = None
        self.pilot = None
        self._mode = None
        self._requests.fail_all("link lost before the vehicle answered")
        self._mode_wanted = None
        self._params_due = math.inf

    def on_message(self, msg: MavMessage, now: float) -> str | None:
        """A message from the vehicle (after the decoder has seen it); words for a
        :class:`~trimd.core.samples.PilotInput` when it shows that someone else changed
        the mode while trimd commanded (trimd has stopped commanding then)."""
        kind = msg.get_type()
        self.rates.note(msg)
        if kind == "COMMAND_ACK":
            self._requests.ack(msg)
        elif kind == "HEARTBEAT":
            mode = self.decoder.mode
            if self._mode_wanted is not None and mode == self._mode_wanted[0]:
                done = self._mode_wanted[1]
                self._mode_wanted = None
                self._requests.forget(mavlink2.MAV_CMD_DO_SET_MODE)
                succeed(done)
            if self._mode is not None and mode == self._mode:
                self._mode_reached = True
            elif self.commanding and self._mode_reached and self._mode_wanted is None:
                return self.yield_control(now, f"mode changed to {mode} by another station",
                                          level=False)
        elif kind == "PARAM_VALUE":
            self._params_seen.add(str(msg.param_id))
            if self._params_wanted <= self._params_seen and self._params_due < math.inf:
                self._params_due = -math.inf  # all answered: judge them at the next tick
        return None

    @property
    def commanding(self) -> bool:
        """trimd holds an attitude or sends open-loop input (until released or lost)."""
        return self._mode is not None

    def yield_control(self, now: float, why: str, *, level: bool = True) -> str:
        """Someone else flies: stop commanding at once and restore no mode; ``level``
        sends one level attitude target first (ArduSub would hold the last tilted one for
        5 s in ALT_HOLD). Returns ``why``, for the PilotInput sample."""
        if not level:
            self.target = None
        self._restore = None
        self.release(now)
        self.pilot = None
        return why

    @property
    def idle(self) -> bool:
        """No mode change (a restore, say) waits for the vehicle's answer."""
        return mavlink2.MAV_CMD_DO_SET_MODE not in self._requests

    # ---------------------------------------------------------------- commands
    def apply(self, command: Command, now: float, done: Future[None]) -> None:
        """Carry out ``command``; ``done`` completes when the vehicle confirms it."""
        others = self.stations.present(now)
        if self.decoder.vehicle is None:
            fail(done, "no vehicle heartbeat yet")
        elif isinstance(command, HoldAttitude) and self.target is not None:
            # already holding (the next hold, or its heading moved along): no mode change
            self.target = (command.phi, command.theta, command.psi)
            self._due["target"] = now
            succeed(done)
        elif isinstance(command, HoldAttitude):
            self.target = (command.phi, command.theta, command.psi)
            self.pilot = _NEUTRAL
            self._due["target"] = self._due["pilot"] = now
            self._change_mode("ALT_HOLD", now, done)
        elif isinstance(command, OpenLoop) and (others or self.options.ids != "gcs"):
            fail(done, "open-loop input needs trimd to be the only ground station; " + (
                f"{self.stations.describe(others[0])} is connected and has the sticks"
                if others else "with ids=vehicle it is none (ArduSub takes MANUAL_CONTROL "
                "only from SYSID_MYGCS)"))
        elif isinstance(command, OpenLoop):
            self.target = None
            self.pilot = pilot_axes(command.axes)
            self._due["pilot"] = now
            self._change_mode("MANUAL", now, done)
        elif isinstance(command, Release):
            self.release(now)
            succeed(done)
        elif isinstance(command, Arm):
            verb = "arm" if command.armed else "disarm"
            self._command(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, (float(command.armed),), now,
                          lambda r: succeed(done) if r == ACCEPTED else fail(
                              done, f"the vehicle did not {verb}: {result_name(r)}"), done)
        else:
            fail(done, f"not supported over MAVLink: {command!r}")

    def release(self, now: float) -> None:
        """Level the vehicle, stop targeting and pilot input; restore the operator's mode."""
        if self.target is not None:
            self._send_target((0.0, 0.0, self.target[2]), now)
        self.target = None
        self.pilot = _NEUTRAL if self.options.pilot == "always" else None
        self._mode = None
        if self._mode_wanted is not None:
            fail(self._mode_wanted[1], "released before the mode changed")
            self._mode_wanted = None
        restore, self._restore = self._restore, None
        if restore is not None and self.decoder.mode != restore:
            self._change_mode(restore, now, None)

    def _change_mode(self, mode: str, now: float, done: Future[None] | None) -> None:
        if done is not None:  # a command (not a restore): trimd flies in this mode now
            self._mode, self._mode_reached = mode, False
        if self.decoder.mode == mode:
            succeed(done)
            return
        if self._restore is None and done is not None:
            self._restore = self.decoder.mode
        if self._mode_wanted is not None:
            fail(self._mode_wanted[1], f"superseded by a change to {mode}")
        wanted = self._mode_wanted = (mode, done)

        def answered(result: int | None) -> None:
            if self._mode_wanted is wanted:
                self._mode_wanted = None
            if result == ACCEPTED:
                succeed(done)
                return
            text = f"the vehicle did not change to {mode}: {result_name(result)}"
            if done is None:
                self.warn(text)
            fail(done, text)

        self._command(mavlink2.MAV_CMD_DO_SET_MODE, (1.0, float(mode_number(mode))), now,
                      answered, done)

    def _command(self, command: int, params: tuple[float, ...], now: float,
                 answered: Callable[[int | None], None], done: Future[None] | None) -> None:
        self._requests.send(command, params, now, answered, done)

    # ---------------------------------------------------------------- periodic
    def tick(self, now: float) -> float:
        """Send whatever is due at ``now``; return when something is due next."""
        due = self._due
        vehicle = self.decoder.vehicle
        if vehicle is None:
            return math.inf
        sysid, compid = vehicle
        if self.target is not None and now >= due["target"]:
            self._send_target(self.target, now)
            due["target"] = now + HOLD_PERIOD_S
        if self.pilot is not None and now >= due["pilot"]:
            self._send_pilot(sysid, now)
            due["pilot"] = now + PILOT_PERIOD_S
        self._tick_requests(now, sysid, compid)
        if not self._streams:
            self._check_rates()
        if now >= self._params_due:
            self._params_answered(now)
        waits = [self._params_due, *self._requests.due()]
        if self.target is not None:
            waits.append(due["target"])
        if self.pilot is not None:
            waits.append(due["pilot"])
        return min(waits)

    def _send_pilot(self, sysid: int, now: float) -> None:
        """MANUAL_CONTROL, only while no other ground station is present (and never as a
        component of the vehicle, ``ids=vehicle``: ArduSub would ignore it)."""
        if self.pilot is None or self.stations.present(now) or self.options.ids != "gcs":
            return
        if self.pilot == _NEUTRAL:
            self.warn("no other ground station seen: trimd sends neutral MANUAL_CONTROL "
                      "(ArduSub's pilot-input failsafe) " + (
                          "from the first heartbeat on (pilot=always)"
                          if self.options.pilot == "always" else "while it commands"))
        x, y, z, r, s, t, ext = self.pilot
        self.mav.manual_control_send(sysid, x, y, z, r, 0, 0, ext, s, t)

    def _send_target(self, target: tuple[float, float, float], now: float) -> None:
        """SET_ATTITUDE_TARGET for (roll, pitch, yaw) [rad], throttle and rates ignored."""
        if self.decoder.vehicle is None:
            return
        sysid, compid = self.decoder.vehicle
        self.mav.set_attitude_target_send(round(now * 1000) & 0xFFFFFFFF, sysid, compid,
                                          _TYPE_MASK, quaternion_from_euler(*target),
                                          0.0, 0.0, 0.0, 0.5)

    def _tick_requests(self, now: float, sysid: int, compid: int) -> None:
        if self._streams and mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL not in self._requests:
            self._request_stream(self._streams.popleft(), now)
        self._requests.tick(now, sysid, compid)

    def _check_rates(self) -> None:
        """Ask again for each watched message that arrives too slowly."""
        for name, got in self.rates.low():
            asked = self.rates.asked[name]
            self.rates.forget(name)
            self._streams.append(name)
            text = (f"the vehicle sent {name} at {got:.1f} Hz, not the {asked:g} Hz trimd "
                    "asked for (another ground station's rate request?): asked again, and "
                    "will whenever it happens again")
            if not self._rates_warned:
                self._rates_warned = True
                self.warn(text)
            else:
                log.info("%s", text)

    def _request_stream(self, name: str, now: float) -> None:
        msg_id, hz, stream = STREAMS[name]
        if self.options.stream_hz is not None and name in self._watched:
            hz = self.options.stream_hz

        def answered(result: int | None) -> None:
            if name in self._watched and result is not None:
                self.rates.asked_for(name, hz)
            if result == ACCEPTED:
                return
            sysid, compid = self.decoder.vehicle or (0, 0)
            self.mav.request_data_stream_send(sysid, compid, stream, round(hz), 1)
            self.warn(f"SET_MESSAGE_INTERVAL {name} at {hz:g} Hz: {result_name(result)}; "
                      f"asked with REQUEST_DATA_STREAM (stream {stream}) instead")

        self._command(mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL,
                      (float(msg_id), 1e6 / hz), now, answered, None)

    # ---------------------------------------------------------------- parameters
    def _request_params(self, names: list[str], now: float) -> None:
        sysid, compid = self.decoder.vehicle or (0, 0)
        for name in names:
            self.mav.param_request_read_send(sysid, compid, name.encode(), -1)
        self._params_tries += 1
        self._params_due = now + _PARAM_WAIT_S

    def _params_answered(self, now: float) -> None:
        missing = sorted(self._params_wanted - self._params_seen)
        if missing and self._params_tries < 2:
            self._request_params(missing, now)
            return
        self._params_due = math.inf
        if not self._params_seen:
            self.warn("the vehicle answered no parameter read (FRAME_CONFIG, SERVOn_FUNCTION, "
                      "MOT_n_DIRECTION): thruster outputs and directions as the profile says")
        for text in self.decoder.params.disagreements(self.profile):
            self.warn(f"vehicle parameters disagree with the profile: {text}")
