"""``trimd sim``: serve the simulated vehicle on a real transport (an ArduSub over MAVLink,
or the serial line protocol on a pseudo-terminal: ``--serve serial:pty``).

Example: ``trimd sim --profile bluerov2-heavy --payload 0.4@W-aft-ctr --serve
mavlink:udpout:127.0.0.1:14550 --rate 10``. ``--serve`` again adds endpoints, as BlueOS's
MAVLink router does (e.g. trimd on one, a pilot's ground station on another): each sees
the vehicle and the other's packets. The vehicle boots like ArduSub: disarmed, in
MANUAL, at the start depth. Exit codes: 0 after ``--duration`` or Ctrl-C, 2 for a usage or
profile error, 3 when the transport cannot be opened.
"""

from __future__ import annotations

import argparse
import math
import threading

from trimd.app.connect import parse_link_url
from trimd.cli.argtypes import Subcommands
from trimd.core.errors import LinkError, ProfileError
from trimd.core.profile_yaml import load_profile

__all__ = ["DEFAULT_SERVE", "register", "run"]

DEFAULT_SERVE = "mavlink:udpout:127.0.0.1:14550"


def register(sub: Subcommands) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "sim", help="serve the simulated vehicle (ArduSub over MAVLink)",
        description="Run the built-in simulated vehicle with a hidden payload and serve it "
        "as an ArduSub vehicle, for ground stations, MAVProxy and trimd run --link mavlink:…")
    p.add_argument("--profile", required=True, help="vehicle profile (YAML path or name)")
    p.add_argument("--payload", action="append", default=[], metavar="KG@WHERE",
                   help="hidden payload: 10@AftSB, 3.5@0.2,-0.1,0.05 (kg at slot or body "
                   "position in m), negative kg for a float; repeatable")
    p.add_argument("--serve", action="append", default=[],
                   help="mavlink:udpout:HOST:PORT | mavlink:udpin:HOST:PORT | "
                   "mavlink:tcpin:HOST:PORT | serial:pty (a pseudo-terminal speaking "
                   "docs/serial-protocol.md; its path is printed); repeat for more MAVLink "
                   f"endpoints behind one router (default {DEFAULT_SERVE})")
    p.add_argument("--rate", type=float, default=1.0,
                   help="simulated seconds per wall second (default 1: real time)")
    p.add_argument("--seed", type=int, default=0, help="seed of noise, bias and current")
    p.add_argument("--options", default="", metavar="KEY=VALUE,…",
                   help="more simulator options, as in a sim: link (docs/simulator.md)")
    p.add_argument("--duration", type=float, default=math.inf,
                   help="stop after this many simulated seconds")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Build the vehicle and serve it until the duration ends or Ctrl-C."""
    from trimd.drivers.sim.config import SimConfig, parse_sim_options
    from trimd.drivers.sim.mavlink_server import MavlinkServer
    from trimd.drivers.sim.serial_server import SerialServer
    from trimd.drivers.sim.vehicle import SimVehicle

    profile = load_profile(args.profile)
    urls = args.serve or [DEFAULT_SERVE]
    devices = []
    for url in urls:
        scheme, device = parse_link_url(url)
        if scheme != "mavlink" and ((scheme, device) != ("serial", "pty") or len(urls) > 1):
            raise LinkError("trimd sim serves mavlink:… (one or more endpoints) or one "
                            f"serial:pty, not '{url}'")
        devices.append(device)
    device = ", ".join(devices)
    base = SimConfig(armed=False, mode="MANUAL", seed=args.seed,
                     payload="+".join(args.payload))
    config = parse_sim_options(args.options, base)
    try:
        vehicle = SimVehicle(profile, config)
    except ProfileError:
        raise
    except ValueError as exc:
        raise LinkError(f"simulator options: {exc}") from None
    server: MavlinkServer | SerialServer
    try:
        if scheme == "serial":
            server = SerialServer(vehicle, rate=args.rate)
            device, speaks = server.path, "the trimd serial protocol"
        else:
            server = MavlinkServer(vehicle, devices, rate=args.rate)
            speaks = "ArduSub"
    except OSError as exc:
        raise LinkError(f"cannot open {device}: {exc}") from None
    print(f"trimd sim: {profile.name} ({config.payload or 'no payload'}, seed {config.seed}) "
          f"as {speaks} on {device} at {args.rate:g}× real time", flush=True)
    stop = threading.Event()
    try:
        server.run(stop, args.duration)
    except KeyboardInterrupt:
        stop.set()
    return 0

