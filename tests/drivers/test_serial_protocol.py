"""The serial line protocol: every conversion by hand, the parser's counters, and fuzzing.

Fuzz tests run ``TRIMD_FUZZ_EXAMPLES`` examples each (default 10 000, the CI figure; set
it lower while iterating). Each example is a few hundred bytes, so the file stays fast.
"""

from __future__ import annotations

import math
import os
import random
from dataclasses import astuple

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from trimd.core.samples import (
    Arm,
    Attitude,
    Battery,
    Depth,
    Health,
    HoldAttitude,
    ModeClass,
    OpenLoop,
    PilotInput,
    Release,
    Sample,
    Thrusters,
    VehicleText,
    Velocity,
)
from trimd.drivers.mavlink.decode import LIMITS
from trimd.drivers.serial.modes import mode_class
from trimd.drivers.serial.protocol import (
    BAD_COUNTERS,
    MAX_LINE_BYTES,
    TRIMD,
    VEHICLE,
    Heartbeat,
    LineParser,
    Sentence,
    Version,
    checksum,
    encode,
    encode_command,
    encode_sample,
    heading_deg,
    to_command,
    to_sample,
)

settings.register_profile(
    "trimd-serial-fuzz", max_examples=int(os.environ.get("TRIMD_FUZZ_EXAMPLES", "3000")),
    deadline=None, suppress_health_check=[HealthCheck.too_slow])
FUZZ = settings.get_profile("trimd-serial-fuzz")

CHANNELS = (3, 1, 8)   # a profile's thrusters on outputs 3, 1 and 8, in that order
DEG = math.pi / 180


def frame(body: str) -> bytes:
    """``body`` framed with a correct checksum (for hand-made lines)."""
    return b"$%s*%02X\r\n" % (body.encode(), checksum(body.encode()))


def parse_one(line: bytes, talker: str = VEHICLE) -> tuple[Sentence | None, LineParser]:
    parser = LineParser(talker)
    out = parser.feed(line)
    assert len(out) <= 1
    return (out[0] if out else None), parser


def vehicle_sample(line: bytes, t_s: float = 7.0) -> Sample | Version | None:
    sentence, parser = parse_one(line)
    assert sentence is not None, parser.counts
    return to_sample(sentence, t_s, CHANNELS)


# ---------------------------------------------------------------------- framing
def test_checksum_and_framing_by_hand() -> None:
    # T^R^A^R^M^,^1 = 0x54^0x52^0x41^0x52^0x4D^0x2C^0x31 = 0x45
    assert checksum(b"TRARM,1") == 0x45
    assert encode("TR", "ARM", ["1"]) == b"$TRARM,1*45\r\n"
    # T^R^H^B^T = 0x58
    assert encode("TR", "HBT", []) == b"$TRHBT*58\r\n"
    assert parse_one(b"$TRHBT*58\r\n", TRIMD)[0] == Sentence("TR", "HBT", ())
    assert parse_one(b"$TRHBT*58\n", TRIMD)[0] is not None        # LF alone is fine
    assert parse_one(b"$trhbt*58\r\n", TRIMD)[1].counts["bad_checksum"] == 1


# ---------------------------------------------------------------------- vehicle → trimd
def test_attitude_degrees_to_radians_and_heading_wrap() -> None:
    a = vehicle_sample(frame("VHATT,1500,10.5,-20.25,270,90,-45,180"))
    assert isinstance(a, Attitude) and a.t_s == 7.0
    assert a.phi == pytest.approx(0.18325957145940460, abs=1e-15)   # 10.5°
    assert a.theta == pytest.approx(-0.35342917352885173, abs=1e-15)  # −20.25°
    assert a.psi == pytest.approx(-math.pi / 2)                    # heading 270° → −90°
    assert (a.p, a.q, a.r) == pytest.approx((math.pi / 2, -math.pi / 4, math.pi))


@pytest.mark.parametrize(("yaw_deg", "psi"), [
    (0, 0.0), (90, math.pi / 2), (180, math.pi), (-180, math.pi), (181, -179 * DEG),
    (359.5, -0.5 * DEG), (360, 0.0), (-90, -math.pi / 2), (-360, 0.0)])
def test_wire_yaw_to_psi(yaw_deg: float, psi: float) -> None:
    a = vehicle_sample(frame(f"VHATT,0,0,0,{yaw_deg},0,0,0"))
    assert isinstance(a, Attitude)
    assert a.psi == pytest.approx(psi, abs=1e-12)


def test_thruster_outputs_by_channel_in_profile_order() -> None:
    line = frame("VHTHR,20,8,1100,1200,1300,1400,1500,1600,1700,1800")
    assert vehicle_sample(line) == Thrusters(7.0, (1300.0, 1100.0, 1800.0))
    # a thruster whose output is not driven (0) or not sent at all: no sample
    assert vehicle_sample(frame("VHTHR,20,8,1100,1200,0,1400,1500,1600,1700,1800")) is None
    assert vehicle_sample(frame("VHTHR,20,7,1100,1200,1300,1400,1500,1600,1700")) is None


def test_depth_velocity_battery_status_version() -> None:
    assert vehicle_sample(frame("VHDPT,5,12.345")) == Depth(7.0, 12.345)
    assert vehicle_sample(frame("VHDPT,5,-0.5")) == Depth(7.0, -0.5)   # above the surface
    assert vehicle_sample(frame("VHVEL,5,0.25,-0.125,0.5")) == Velocity(7.0, 0.25, -0.125, 0.5)
    assert vehicle_sample(frame("VHBAT,5,15.92")) == Battery(7.0, 15.92)
    assert vehicle_sample(frame("VHSTA,5,ALT_HOLD,1,HOLD")) == Health(
        7.0, True, "ALT_HOLD", True, detail="control HOLD", mode_class=ModeClass.DEPTH_HOLDING)
    assert vehicle_sample(frame("VHVER,1,sabertooth-dh2")) == Version(1, "sabertooth-dh2")
    assert vehicle_sample(frame("VHTXT,5,2,Leak detected: forward hull!")) == VehicleText(
        7.0, 2, "Leak detected: forward hull!")


def test_encode_samples_by_hand() -> None:
    a = Attitude(0.0, math.pi / 6, -math.pi / 12, -math.pi / 2, 0.1, -0.2, 0.0)
    # 0.1 rad/s = 5.72958°/s, −0.2 rad/s = −11.45916°/s; ψ = −90° goes out as heading 270°
    assert encode_sample(a, 1234) == frame("VHATT,1234,30.000,-15.000,270.000,5.730,-11.459,0")
    t = Thrusters(0.0, (1300.0, 1100.4, 1799.6))
    assert encode_sample(t, 2**32 + 5, 8, CHANNELS) == frame(
        "VHTHR,5,8,1100,0,1300,0,0,0,0,1800")                   # t_ms wraps at 2³²
    assert encode_sample(Depth(0.0, 12.3456), 1) == frame("VHDPT,1,12.346")
    assert encode_sample(Depth(0.0, 20_000.0), 1) == frame("VHDPT,1,11000.000")  # full scale
    assert encode_sample(Velocity(0.0, 0.1, -0.0001, 0.0), 1) == frame("VHVEL,1,0.100,0,0")
    assert encode_sample(Battery(0.0, 15.926), 1) == frame("VHBAT,1,15.93")
    assert encode_sample(Health(0.0, True, "MANUAL", False), 9, control="OPEN") == frame(
        "VHSTA,9,MANUAL,0,OPEN")
    # a text is made to fit: "," → ";", "$", "*" and non-ASCII → "?", at most 96 characters
    assert encode_sample(VehicleText(0.0, 9, "Depth 5 m, 20 °C *$"), 3) == frame(
        "VHTXT,3,7,Depth 5 m; 20 ?C ??")
    long = encode_sample(VehicleText(0.0, 4, "x" * 200), 4_294_967_295)
    assert len(long) < MAX_LINE_BYTES and vehicle_sample(long) == VehicleText(7.0, 4, "x" * 96)


def test_heading() -> None:
    assert heading_deg(0.0) == 0.0
    assert heading_deg(math.pi) == 180.0
    assert heading_deg(-math.pi / 4) == pytest.approx(315.0)


# ---------------------------------------------------------------------- trimd → vehicle
def test_commands_by_hand_and_back() -> None:
    hold = HoldAttitude(10 * DEG, -20 * DEG, -math.pi / 2)
    assert encode_command(hold) == frame("TRHLD,10.000,-20.000,270.000")
    sentence, _ = parse_one(encode_command(hold), TRIMD)
    assert sentence is not None
    back = to_command(sentence)
    assert isinstance(back, HoldAttitude)
    assert (back.phi, back.theta, back.psi) == pytest.approx((hold.phi, hold.theta, hold.psi))
    axes = (0.5, -1.0, 0.25, 0.0, 1.0, -0.125)
    assert encode_command(OpenLoop(axes)) == frame("TROPN,0.500,-1.000,0.250,0,1.000,-0.125")
    assert encode_command(Arm(True)) == frame("TRARM,1")
    assert encode_command(Arm(False)) == frame("TRARM,0")
    assert encode_command(Release()) == frame("TRREL")
    assert encode_command(Heartbeat()) == frame("TRHBT")
    assert encode_command(Version(1, "trimd")) == frame("TRVER,1,trimd")
    for command in (OpenLoop(axes), Arm(True), Arm(False), Release(), Heartbeat(),
                    Version(1, "trimd")):
        sentence, _ = parse_one(encode_command(command), TRIMD)
        assert sentence is not None and to_command(sentence) == command


@pytest.mark.parametrize("command", [
    OpenLoop((1.5, 0, 0, 0, 0, 0)), OpenLoop((math.nan, 0, 0, 0, 0, 0)),
    HoldAttitude(0.0, 100 * DEG, 0.0), HoldAttitude(math.nan, 0.0, 0.0),
    HoldAttitude(0.0, 0.0, math.inf)])
def test_commands_the_protocol_cannot_carry_are_refused(command: OpenLoop | HoldAttitude
                                                        ) -> None:
    with pytest.raises(ValueError, match=r"cannot hold|open-loop"):
        encode_command(command)


def test_a_pilot_taking_over_has_no_sentence_of_its_own() -> None:
    with pytest.raises(ValueError, match="STA with control PILOT"):
        encode_sample(PilotInput(0.0, "sticks"), 0)


# ---------------------------------------------------------------------- the number grammar
#: Every form docs/serial-protocol.md allows for a number, ``[+-]digits[.digits]`` or
#: ``.digits``, with the value it stands for.
NUMBERS_ALLOWED = {"5": 5.0, "+5": 5.0, "-5": -5.0, "05": 5.0, "0": 0.0, "-0": 0.0,
                   "5.25": 5.25, "+5.25": 5.25, "-5.25": -5.25, "5.250": 5.25,
                   "0.000": 0.0, ".5": 0.5, ".05": 0.05, "10999.9": 10999.9}
#: Forms it forbids: a point without digits after it, a sign before ``.digits``, a bare
#: sign or point, exponents, nan/inf, spaces, ``_``, hex, doubled signs or points.
NUMBERS_FORBIDDEN = ["9.", "+5.", "-5.", "-.5", "+.5", ".", "+", "-", "", " 5", "5 ",
                     "+-5", "--5", "++5", "5.2.1", "5..2", "1e3", "1E3", "1e-3", "nan",
                     "NaN", "inf", "-inf", "Infinity", "1_0", "0x10", "5d", "five"]
#: Integers: unsigned strings of 1 to 10 digits.
INTEGERS_ALLOWED = {"0": 0, "7": 7, "0042": 42, "4294967295": 2**32 - 1}
INTEGERS_FORBIDDEN = ["+5", "-5", "5.0", "5.", ".5", "", " 5", "1e3", "12345678901",
                      "00000000001", "0x1F", "1_0"]


@pytest.mark.parametrize(("text", "value"), NUMBERS_ALLOWED.items())
def test_every_number_form_the_grammar_allows_is_read(text: str, value: float) -> None:
    parser = LineParser(VEHICLE)
    [sentence] = parser.feed(frame(f"VHDPT,1,{text}"))
    assert sentence.values == (1, value) and parser.counts == {"ok": 1}


@pytest.mark.parametrize("text", NUMBERS_FORBIDDEN)
def test_every_number_form_the_grammar_forbids_is_a_bad_value(text: str) -> None:
    parser = LineParser(VEHICLE)
    assert parser.feed(frame(f"VHDPT,1,{text}")) == []
    assert parser.counts == {"bad_value": 1}


@pytest.mark.parametrize(("text", "value"), INTEGERS_ALLOWED.items())
def test_every_integer_form_the_grammar_allows_is_read(text: str, value: int) -> None:
    parser = LineParser(VEHICLE)
    [sentence] = parser.feed(frame(f"VHDPT,{text},2.5"))
    assert sentence.values == (value, 2.5)


@pytest.mark.parametrize("text", INTEGERS_FORBIDDEN)
def test_every_integer_form_the_grammar_forbids_is_a_bad_value(text: str) -> None:
    parser = LineParser(VEHICLE)
    for line in (f"VHDPT,{text},2.5", f"VHTHR,1,1,{text}"):   # t_ms, a PWM output
        assert parser.feed(frame(line)) == []
    assert parser.counts == {"bad_value": 2}


# ---------------------------------------------------------------------- bad lines
@pytest.mark.parametrize(("line", "counter"), [
    (b"$VHDPT,1," + b"1" * MAX_LINE_BYTES + b"*00\r\n", "too_long"),
    (b"VHDPT,1,2.0*4B\r\n", "malformed"),                      # no $
    (b"$VHDPT,1,2.0\r\n", "malformed"),                        # no checksum
    (b"$VHDPT,1,2.0*4\r\n", "malformed"),                      # one hex digit
    (b"$VHDPT,1,\xb02.0*4B\r\n", "malformed"),                 # not ASCII
    (frame("VHDPT,1,2.0").replace(b"2.0", b"2.1"), "bad_checksum"),
    (frame("VHXYZ,1,2.0"), "unknown"),
    (frame("TRHLD,0,0,0"), "unknown"),                         # trimd's own sentence
    (frame("VHDPT,1"), "bad_fields"),
    (frame("VHDPT,1,2.0,3.0"), "bad_fields"),
    (frame("VHTHR,1,3,1500,1500"), "bad_fields"),              # 3 outputs announced
    (frame("VHTHR,1,17" + ",1500" * 17), "bad_value"),         # more than 16 outputs
    (frame("VHDPT,1,nan"), "bad_value"),
    (frame("VHDPT,1,inf"), "bad_value"),
    (frame("VHDPT,1,1e3"), "bad_value"),                       # no exponents
    (frame("VHDPT,1,1_0"), "bad_value"),                       # float("1_0") would be 10
    (frame("VHDPT,1,11000.5"), "bad_value"),                   # deeper than the ocean
    (frame("VHDPT,-1,2.0"), "bad_value"),                      # t_ms is unsigned
    (frame("VHATT,1,0,90.5,0,0,0,0"), "bad_value"),            # pitch beyond 90°
    (frame("VHATT,1,0,0,0,0,0,2000.1"), "bad_value"),
    (frame("VHTHR,1,2,1500,799"), "bad_value"),
    (frame("VHBAT,1,0.5"), "bad_value"),
    (frame("VHSTA,1,alt_hold,1,HOLD"), "bad_value"),
    (frame("VHSTA,1,ALT_HOLD,2,HOLD"), "bad_value"),
    (frame("VHSTA,1,ALT_HOLD,1,AUTO"), "bad_value"),
    (frame("VHTXT,1,8,severity 8"), "bad_value"),
    (frame("VHTXT,1,4,"), "bad_value"),                        # no text
    (frame("VHTXT,1,4,a,b"), "bad_fields"),                    # a comma in the text
    (frame("VHTXT,1,4," + "x" * 97), "bad_value"),
])
def test_each_bad_line_is_counted_once_and_dropped(line: bytes, counter: str) -> None:
    parser = LineParser(VEHICLE)
    good = frame("VHDPT,2,3.5")
    out = parser.feed(good + line + good)
    assert [s.values for s in out] == [(2, 3.5), (2, 3.5)]
    assert parser.counts == {"ok": 2, counter: 1}
    assert parser.bad_lines == 1


def test_blank_lines_are_ignored_and_a_partial_line_waits() -> None:
    parser = LineParser(VEHICLE)
    line = frame("VHDPT,2,3.5")
    assert parser.feed(b"\r\n\n" + line[:7]) == []
    assert len(parser.feed(line[7:])) == 1
    assert parser.counts == {"ok": 1}


def test_an_endless_line_is_counted_once_and_the_parser_recovers() -> None:
    parser = LineParser(VEHICLE)
    for _ in range(100):                        # 100 × 100 bytes without a line feed
        assert parser.feed(b"7" * 100) == []
    assert parser.counts == {"too_long": 1}
    assert parser.feed(b"\n" + frame("VHDPT,2,3.5"))[0].values == (2, 3.5)
    assert parser.counts == {"too_long": 1, "ok": 1}


# ---------------------------------------------------------------------- fuzzing
def valid_sample(s: Sample | Version | None) -> bool:
    """Finite and inside the MAVLink decoder's plausible ranges (an independent table)."""
    def ok(value: float, limit: str) -> bool:
        lo, hi = LIMITS[limit]
        return math.isfinite(value) and lo <= value <= hi

    if isinstance(s, Attitude):
        return (ok(s.phi, "roll_rad") and ok(s.theta, "pitch_rad") and ok(s.psi, "yaw_rad")
                and all(ok(w, "rate_rad_s") for w in (s.p, s.q, s.r)))
    if isinstance(s, Thrusters):
        return len(s.pwm_us) == len(CHANNELS) and all(ok(p, "pwm_us") for p in s.pwm_us)
    if isinstance(s, Depth):
        return ok(s.depth_m, "depth_m")
    if isinstance(s, Velocity):
        return all(math.isfinite(x) and abs(x) <= 20 for x in (s.u, s.v, s.w))
    if isinstance(s, Battery):
        return ok(s.voltage_V, "voltage_V")
    if isinstance(s, Health):
        return s.mode.isupper() or s.mode.isidentifier()
    if isinstance(s, VehicleText):
        return 0 <= s.severity <= 7 and 0 < len(s.text) <= 96 and "," not in s.text
    return s is None or isinstance(s, Version)


def valid_command(c: object) -> bool:
    if isinstance(c, HoldAttitude):
        return (abs(c.phi) <= math.pi and abs(c.theta) <= math.pi / 2
                and -math.pi < c.psi <= math.pi)
    if isinstance(c, OpenLoop):
        return len(c.axes) == 6 and all(abs(a) <= 1 for a in c.axes)
    return isinstance(c, Arm | Release | Heartbeat | Version)


def expected_lines(data: bytes) -> tuple[int, int]:
    """(too long, other counted) lines of a stream, from its line feeds alone."""
    *complete, rest = data.split(b"\n")
    too_long = sum(len(x) >= MAX_LINE_BYTES for x in complete) + (len(rest) >= MAX_LINE_BYTES)
    other = sum(len(x) < MAX_LINE_BYTES and x not in (b"", b"\r") for x in complete)
    return too_long, other


def feed_in_chunks(parser: LineParser, data: bytes, cuts: list[int]) -> list[Sentence]:
    out, start = [], 0
    for cut in [*sorted(cuts), len(data)]:
        out += parser.feed(data[start:cut])
        start = max(start, cut)
    return out


_SOUP = st.lists(st.sampled_from([
    b"$", b"*", b",", b"\n", b"\r", b"VH", b"TR", b"ATT", b"THR", b"DPT", b"STA", b"HLD",
    b"OPN", b"1", b"-", b".", b"0", b"9", b"8", b"nan", b"\xff", b"*00", b"*5C"]), max_size=60)


_EDGES = ["0", "1", "-1", "-0", ".5", "5.", "89.999", "90", "90.5", "-180", "180.001", "360",
          "360.5", "2000", "-2000.01", "20", "20.5", "799", "800", "2200", "2201", "16", "17",
          "11000", "-10.5", "100.1", "0.9", "4294967295", "4294967296", "", " ", "nan", "inf",
          "1e3", "1_0", "ALT_HOLD", "manual", "HOLD", "AUTO", "x" * 33]
#: a valid line of each sentence, whose fields the fuzzer replaces by edge cases
_TEMPLATES = {"VHATT": "1,0,0,0,0,0,0", "VHTHR": "1,8" + ",1500" * 8, "VHDPT": "1,5",
              "VHVEL": "1,0,0,0", "VHBAT": "1,16", "VHSTA": "1,MANUAL,1,PILOT",
              "VHVER": "1,sim", "VHTXT": "1,4,Leak", "TRVER": "1,trimd", "TRHBT": "",
              "TRHLD": "0,0,0", "TRREL": "", "TROPN": "0,0,0,0,0,0", "TRARM": "1", "VHXYZ": "1"}


def _edge_line(address: str, edits: list[tuple[int, str]]) -> bytes:
    fields = _TEMPLATES[address].split(",") if _TEMPLATES[address] else []
    for index, edge in edits:
        if fields:
            fields[index % len(fields)] = edge
    return frame(",".join([address, *fields]))


#: lines with a correct checksum: a valid template with up to three fields at their edges
_FRAMED = st.lists(st.builds(_edge_line, st.sampled_from(list(_TEMPLATES)), st.lists(
    st.tuples(st.integers(0, 9), st.sampled_from(_EDGES)), max_size=3)), max_size=8).map(
    b"".join)


@pytest.mark.slow
@FUZZ
@given(st.one_of(st.binary(max_size=300), _SOUP.map(b"".join), _FRAMED),
       st.lists(st.integers(0, 300), max_size=6))
def test_random_bytes_never_raise_and_every_line_is_accounted_for(data: bytes,
                                                                  cuts: list[int]) -> None:
    for talker in (VEHICLE, TRIMD):
        whole = LineParser(talker)
        sentences = whole.feed(data)
        chunked = LineParser(talker)
        assert feed_in_chunks(chunked, data, cuts) == sentences   # chunking never matters
        assert chunked.counts == whole.counts
        too_long, other = expected_lines(data)
        assert whole.counts["too_long"] == too_long
        assert sum(whole.counts.values()) - too_long == other
        for s in sentences:
            if talker == VEHICLE:
                assert valid_sample(to_sample(s, 1.0, CHANNELS)), s
            else:
                assert valid_command(to_command(s)), s


KINDS = ("attitude", "thrusters", "depth", "velocity", "battery", "health")
MUTATIONS = ("ok", "ok", "bad_checksum", "too_long", "bad_fields", "unknown", "bad_value",
             "malformed")


def random_sample(kind: str, rng: random.Random) -> Sample:
    u = rng.uniform
    if kind == "attitude":
        return Attitude(0.0, u(-math.pi, math.pi), u(-math.pi / 2, math.pi / 2),
                        u(-math.pi, math.pi), u(-34, 34), u(-34, 34), u(-34, 34))
    if kind == "thrusters":
        return Thrusters(0.0, tuple(float(rng.randint(1100, 1900)) for _ in CHANNELS))
    if kind == "depth":
        return Depth(0.0, u(-10, 11_000))
    if kind == "velocity":
        return Velocity(0.0, u(-20, 20), u(-20, 20), u(-20, 20))
    if kind == "battery":
        return Battery(0.0, u(1, 100))
    mode = rng.choice(["MANUAL", "ALT_HOLD", "STABILIZE", "SURFACE", "MY_MODE"])
    return Health(0.0, True, mode, rng.random() < 0.5, detail="control PILOT",
                  mode_class=mode_class(mode))


def mutate(line: bytes, how: str, rng: random.Random) -> bytes:
    """``line`` broken so that exactly counter ``how`` drops it ("ok": unchanged)."""
    body = line[1:line.index(b"*")].decode()
    fields = body.split(",")
    if how == "bad_checksum":
        return b"$%s*%02X\r\n" % (body.encode(), checksum(body.encode()) ^ rng.randint(1, 255))
    if how == "too_long":
        return frame(body + "," + "0" * MAX_LINE_BYTES)
    if how == "bad_fields":
        return frame(",".join(fields[:-1]))
    if how == "unknown":
        return frame(",".join([rng.choice(["VHXYZ", "TRATT", "VHAT", "GPGGA"]), *fields[1:]]))
    if how == "bad_value":
        return frame(",".join([*fields[:-1], rng.choice([" ", "nan", "+", "1e3", "0x1",
                                                         "99999", "-99999"])]))
    if how == "malformed":
        noise = bytes(rng.randrange(256) for _ in range(rng.randint(0, 40))).replace(b"\n", b"")
        return b"#" + noise + b"\n"
    return line


def close(a: Sample | Version | None, b: Sample) -> bool:
    """A decoded sample equals the encoded one within the wire's resolution."""
    if isinstance(a, Attitude) and isinstance(b, Attitude):
        dpsi = (a.psi - b.psi + math.pi) % (2 * math.pi) - math.pi
        return (abs(dpsi) < 1e-5 and all(abs(x - y) < 1e-5 for x, y in
                                         zip((a.phi, a.theta, a.p, a.q, a.r),
                                             (b.phi, b.theta, b.p, b.q, b.r), strict=True)))
    if isinstance(a, Depth | Velocity | Battery) and type(a) is type(b):
        tol = 0.0051 if isinstance(a, Battery) else 0.00051
        return all(abs(x - y) <= tol for x, y in zip(astuple(a)[1:], astuple(b)[1:],
                                                      strict=True))
    return a == b


@pytest.mark.slow
@FUZZ
@given(st.lists(st.tuples(st.sampled_from(KINDS), st.sampled_from(MUTATIONS),
                          st.integers(0, 2**32 - 1)), max_size=12),
       st.lists(st.integers(0, 1500), max_size=4))
def test_mutated_streams_count_exactly_what_was_broken(
        script: list[tuple[str, str, int]], cuts: list[int]) -> None:
    lines, expected, sent = [], {k: 0 for k in ("ok", *BAD_COUNTERS)}, []
    for kind, how, seed in script:
        rng = random.Random(seed)
        sample = random_sample(kind, rng)
        line = encode_sample(sample, seed, 8, CHANNELS)
        lines.append(mutate(line, how, rng))
        expected["ok" if how == "ok" else how] += 1
        if how == "ok":
            sent.append(sample)
    parser = LineParser(VEHICLE)
    got = feed_in_chunks(parser, b"".join(lines), cuts)
    assert {k: parser.counts[k] for k in expected} == expected
    assert len(got) == len(sent)
    for sentence, sample in zip(got, sent, strict=True):
        decoded = to_sample(sentence, 0.0, CHANNELS)
        assert valid_sample(decoded) and close(decoded, sample), (decoded, sample)
