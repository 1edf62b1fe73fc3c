"""The `humanoid` command's commands: serve, run, behaviours, transcribe, plan, estop, describe, sessions, hardware,
users, db, service, doctor, bench."""

from __future__ import annotations

import argparse
import json
import ssl
import sys

from app.auth.cli import add_users_parser
from app.cli.hardware import add_hardware_parser
from app.cli.hil import add_hil_parser
from app.deploy.db_cli import add_db_parser
from app.deploy.doctor.cli import add_doctor_parser
from app.deploy.service_cli import add_service_parser
from app.sessions.cli import add_sessions_parser
from app.settings import Settings, get_settings


def _serve(args: argparse.Namespace, settings: Settings) -> int:
    import uvicorn

    from app.auth.access import InsecureBind
    from app.sessions.db import upgrade_to_head
    from app.web.main import create_app

    http_port, device = _split_port(args.port)
    overrides = {
        "seed": args.seed,
        "enable_mirror": False if args.no_mirror else None,  # (else HUMANOID_ENABLE_MIRROR's)
        "host": args.host,
        "port": args.http_port or http_port,
        "backend": args.backend,
        "dynamixel_port": device,
        "robot_config": args.robot_config,
        "imu": args.imu,
        "feet": args.feet,
        "camera": args.camera,
        "lidar": args.lidar,
    }
    settings = settings.model_copy(update={k: v for k, v in overrides.items() if v is not None})
    if args.viser_port is not None:
        settings = settings.model_copy(update={"viser_port": args.viser_port})
    if args.tls or args.tls_cert or args.tls_key:
        try:
            tls = _tls_files(args, settings)
        except (OSError, ValueError) as exc:
            print(f"humanoid serve: {exc}", file=sys.stderr)
            return 2
        settings = settings.model_copy(update={"tls_cert": tls.cert, "tls_key": tls.key})
    if args.foxglove_port is not None:
        settings = settings.model_copy(update={"foxglove_port": args.foxglove_port})
    upgrade_to_head(settings.database_url)
    try:  # said here plainly, before anything starts (Runtime.start checks again)
        _access_control(settings).check_exposure()
    except InsecureBind as exc:
        print(f"humanoid serve: {exc}", file=sys.stderr)
        return 2
    # Threads here (HTTP, WebSockets, the 3D mirror, the recorder) share one interpreter lock; a short switch
    # interval bounds how long the e-stop relay can wait for it behind a busy thread.
    sys.setswitchinterval(0.0005)
    scheme = "https" if settings.tls_files() else "http"
    print(f"Humanoid mission control: {scheme}://{settings.host}:{settings.port}")
    print(
        f"  3D views on ports {settings.viser_port} (full) and {settings.viser_light_port} (light); "
        f"session replay on {settings.replay_port}"
    )
    if settings.foxglove_port is not None:
        print(f"  Foxglove: ws://127.0.0.1:{settings.foxglove_port}, and ws://{settings.host}:{settings.port}/foxglove")
    # No per-message compression: deflating each page's copy of each state cost ~12 % of this process's interpreter
    # lock with 20 pages (`humanoid bench load`); the e-stop waits behind whatever holds that lock.
    uvicorn.run(
        create_app(settings, relay_priority=True),
        host=settings.host,
        port=settings.port,
        log_level="warning",
        ws_max_size=65536,
        ws_per_message_deflate=False,
        ssl_certfile=settings.tls_cert or None,
        ssl_keyfile=settings.tls_key or None,
    )
    return 0


def _tls_files(args: argparse.Namespace, settings: Settings):  # type: ignore[no-untyped-def]
    """The certificate given (both files, readable and matching), or the robot's own for its names (made once)."""
    from pathlib import Path

    from app.web.tls import TlsFiles, ensure_certificate

    if args.tls_cert or args.tls_key:
        if not (args.tls_cert and args.tls_key):
            raise ValueError("--tls-cert and --tls-key go together")
        files = TlsFiles(args.tls_cert, args.tls_key)
        try:
            files.server_context()
        except ssl.SSLError as exc:
            raise ValueError(f"cannot use {args.tls_cert} with {args.tls_key}: {exc}") from exc
        return files
    files = ensure_certificate(Path(settings.data_dir) / "tls", settings.host)
    ca = Path(files.cert).parent / "ca.pem"
    print(f"HTTPS with this robot's own certificate: browsers trust it once they import {ca}")
    return files


def _access_control(settings: Settings):  # type: ignore[no-untyped-def]
    from app.auth.access import AccessControl
    from app.auth.store import UserStore
    from app.sessions.db import make_engine, make_session_factory

    return AccessControl(
        settings.auth, UserStore(make_session_factory(make_engine(settings.database_url))), settings.host
    )


def _split_port(value: str | None) -> tuple[int | None, str | None]:
    """`--port 8000` is the HTTP port; `--port /dev/ttyUSB0` (anything not a number) the real robot's bus."""
    if value is None:
        return None, None
    return (int(value), None) if value.isdigit() else (None, value)


def _transcribe_file(path: str, engine: str | None, seed: int, settings: Settings) -> dict:
    """Transcribe an audio file with the world's names as hints, and say whether it is a spoken stop (as the
    robot's microphone and the page would: the stop spotter, or the transcript's words)."""
    from robot.model.world import generate_world
    from robot.planning.world_context import WorldContext
    from robot.speech.audio import read_audio
    from robot.speech.engines import build_recognizer
    from robot.speech.stop_word import StopSpotter, transcript_is_stop

    world = WorldContext.from_layout(generate_world(seed))
    audio = read_audio(path)
    engine = engine or settings.asr_engine
    recognizer = build_recognizer(
        engine, world.objects, world.places, settings.whisper_model_dir, settings.whisper_second_model, world
    )
    verdict = StopSpotter(world.objects, world.places).spot(audio)
    transcript = recognizer.transcribe(audio)
    return {
        "text": transcript.text,
        "confidence": round(transcript.confidence, 3),
        "engine": transcript.engine,
        "in_grammar": transcript.in_grammar,
        "audio_s": round(transcript.audio_s, 3),
        "decode_ms": round(transcript.decode_s * 1000, 1),
        "alternatives": list(transcript.alternatives),
        "unsure_names": list(transcript.unsure_names),
        "heard_again": transcript.heard_again,
        # the engine's likeliest wording when `text` is the likeliest that is one of the world's commands
        "first_heard": transcript.first_heard,
        # further down the beam: only the spoken stop looks at them
        "further_wordings": list(transcript.further_wordings),
        "stop_word": verdict.stop or transcript_is_stop(transcript),
    }


def _transcribe(args: argparse.Namespace, settings: Settings) -> int:
    from robot.speech.asr import ASRError
    from robot.speech.audio import AudioError

    try:
        result = _transcribe_file(args.file, args.engine, args.seed, settings)
    except (AudioError, ASRError) as exc:
        print(f"cannot transcribe: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(
            f"{result['text']!r} (confidence {result['confidence']:.2f}, {result['engine']}, "
            f"{result['decode_ms']:.0f} ms for {result['audio_s']:.1f} s)"
        )
    return 0 if result["text"] else 1


def _run(args: argparse.Namespace, settings: Settings) -> int:
    from app.cli.headless import run_command

    heard = None
    if args.audio:
        from robot.speech.asr import ASRError
        from robot.speech.audio import AudioError

        try:
            heard = _transcribe_file(args.audio, None, args.seed, settings)
        except (AudioError, ASRError) as exc:
            print(f"cannot transcribe {args.audio}: {exc}", file=sys.stderr)
            return 2
        if not heard["text"]:
            print(f"nothing recognised in {args.audio}", file=sys.stderr)
            return 1
        args.text = heard["text"]
    if not args.text:
        print("give a command, or --audio FILE.wav", file=sys.stderr)
        return 2
    recording = None
    if heard is not None:
        from robot.speech.audio import read_audio

        recording = (heard, read_audio(args.audio).wav_bytes())
    result = run_command(
        args.text, seed=args.seed, settings=settings, timeout_s=args.timeout, heard=recording, backend=args.backend
    )
    if heard is not None:
        result["speech"] = {**heard, "file": args.audio}
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(
            f"{'SUCCESS' if result['success'] else 'FAILED'}: {result['transcript']!r} (session {result['session_id']})"
        )
        if "error" in result:
            print(f"  {result['error']}")
        for step in result["steps"]:
            detail = f" ({step['detail']})" if step["detail"] else ""
            print(f"  {step['action']}({', '.join(step['args'].values())}): {step['status']}{detail}")
        print(f"  sim {result['sim_time_s']:.2f} s, wall {result['wall_time_s']:.2f} s, fell: {result['fell']}")
    return 0 if result["success"] else 1


def _plan(args: argparse.Namespace, settings: Settings) -> int:
    """Plan a command against the world of a seed without moving anything: the validated plan, in the seed's
    format (a JSON list of actions)."""
    from robot.model.world import generate_world
    from robot.planning.context import PlanningContext
    from robot.planning.pipeline import build_pipeline
    from robot.planning.planner import ClarificationNeeded, PlanningError
    from robot.planning.world_context import WorldContext

    if args.backend:
        settings = settings.model_copy(update={"planner_backend": args.backend})
    world = WorldContext.from_layout(generate_world(args.seed), held_object=args.holding)
    if args.holding and world.resolve_object(args.holding) is None:
        print(f"unknown object {args.holding!r}; known objects: {', '.join(world.objects)}", file=sys.stderr)
        return 2
    if args.holding:
        world = WorldContext.from_layout(generate_world(args.seed), held_object=world.resolve_object(args.holding))
    pipeline = build_pipeline(settings.planner_config())
    try:
        result = pipeline.plan(args.text, PlanningContext(world))
    except ClarificationNeeded as exc:  # two close readings: a question, and no plan
        if args.json:
            print(json.dumps({"clarify": exc.question, "options": list(exc.options), "plan": None}, indent=2))
        else:
            print(f"question: {exc.question}", file=sys.stderr)
        return 1
    except PlanningError as exc:
        print(f"no plan: {exc}", file=sys.stderr)
        return 1
    for note in result.notes:
        print(f"note: {note}", file=sys.stderr)
    if args.json:
        print(json.dumps(result.plan.to_seed_list(), indent=2))
    else:
        print(f"plan by {result.planner} in {result.latency_s * 1000:.1f} ms:")
        for i, step in enumerate(result.plan.steps, start=1):
            print(f"  {i}. {step.action}({', '.join(f'{k}={v!r}' for k, v in step.args.items())})")
    return 0


def _estop(args: argparse.Namespace, settings: Settings) -> int:
    import httpx

    url = args.url or f"http://{settings.host}:{settings.port}"
    path = "/api/estop/reset" if args.release else "/api/estop"
    try:
        response = httpx.post(url + path, json=None if args.release else {"source": "cli"}, timeout=5.0)
    except httpx.HTTPError as exc:
        print(f"could not reach the server at {url}: {exc}", file=sys.stderr)
        return 2
    body = response.json()
    detail = body.get("detail", body)
    print(detail["message"] if isinstance(detail, dict) else detail)
    return 0 if response.is_success else 1


def _describe(args: argparse.Namespace, settings: Settings) -> int:
    """The robot's description: its URDF (--urdf), or a summary of its joints."""
    from pathlib import Path

    from robot.model import humanoid_v1
    from robot.model.urdf import robot_urdf

    if args.urdf:
        text = robot_urdf()
    else:
        lines = [f"{humanoid_v1.MODEL_NAME}: {len(humanoid_v1.JOINT_NAMES)} servo joints (rad; the grippers in m)"]
        lines += [f"  {n:<12} {lim.lower:+.3f} .. {lim.upper:+.3f}" for n, lim in humanoid_v1.joint_limits().items()]
        text = "\n".join(lines) + "\n"
    if args.output:
        Path(args.output).write_text(text)
        print(f"wrote {args.output} ({len(text.encode()) / 1e3:.0f} kB)", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0


def _behaviours_list(args: argparse.Namespace, settings: Settings) -> int:
    from app.cli.headless_behaviour import list_behaviours

    listed = list_behaviours()
    if args.json:
        print(json.dumps(listed, indent=2))
        return 0
    for info in listed["behaviours"]:
        source = f" [{info['package']}]" if info["package"] else ""
        print(f"{info['name']}{source}: {info['description']}")
        for param in info["params"]:
            print(f"  {param['name']} ({param['kind']}, default {param['default']!r}): {param['doc']}")
    for point, reason in listed["broken"].items():
        print(f"(not loaded: {point}: {reason})", file=sys.stderr)
    return 0


def _behaviours_run(args: argparse.Namespace, settings: Settings) -> int:
    from app.cli.headless_behaviour import parse_settings, run_behaviour

    try:
        params = parse_settings(args.set or [])
    except ValueError as exc:
        print(exc, file=sys.stderr)
        return 2
    result = run_behaviour(args.name, params, seed=args.seed, settings=settings, timeout_s=args.timeout)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        outcome = "SUCCESS" if result["success"] else "FAILED"
        print(f"{outcome}: behaviour {args.name} (session {result['session_id']}): {result['state']}")
        if result.get("reason") or result.get("error"):
            print(f"  {result.get('error') or result['reason']}")
        for line in result["feedback"]:
            print(f"  - {line}")
        print(f"  sim {result['sim_time_s']:.2f} s, wall {result['wall_time_s']:.2f} s, fell: {result['fell']}")
    if "errors" in result:
        return 2  # refused: an unknown behaviour or a bad parameter
    return 0 if result["success"] else 1


def _bench(args: argparse.Namespace, settings: Settings) -> int:
    from bench import run_suite

    return run_suite(args.suite, args)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="humanoid", description="Humanoid mission control")
    sub = parser.add_subparsers(dest="command", required=True)

    serve = sub.add_parser("serve", help="start the web app with the simulated robot (real time)")
    serve.add_argument("--host", default=None, help="interface to bind (default 127.0.0.1, or HOST)")
    serve.add_argument(
        "--port",
        default=None,
        help="HTTP port (default 8000, or PORT); with --backend dynamixel, a serial device such as "
        "/dev/ttyUSB0 is the U2D2's",
    )
    serve.add_argument("--http-port", type=int, default=None, help="HTTP port, when --port names the servo bus")
    serve.add_argument(
        "--backend",
        choices=["sim", "dynamixel"],
        default=None,
        help="sim (MuJoCo, the default) or dynamixel (the real robot's XM430s)",
    )
    serve.add_argument("--robot-config", default=None, help="the real robot's configuration file (robot.toml)")
    serve.add_argument(
        "--imu",
        default=None,
        help="with --backend dynamixel: opencr (ID 200 on the servo bus), bno055:/dev/ttyX, or none",
    )
    serve.add_argument("--feet", default=None, help="with --backend dynamixel: fsr (IDs 111, 112 on the bus) or none")
    serve.add_argument(
        "--camera",
        default=None,
        help="with --backend dynamixel: an OpenCV device index, path or stream URL, realsense, or none",
    )
    serve.add_argument("--lidar", default=None, help="with --backend dynamixel: ld06:/dev/ttyY, ld19:/dev/ttyY or none")
    serve.add_argument(
        "--viser-port",
        type=int,
        default=None,
        help="port of the full 3D view (default 8081); the light one is HUMANOID_VISER_LIGHT_PORT (8082)",
    )
    serve.add_argument(
        "--foxglove-port",
        type=int,
        default=None,
        help="start the live Foxglove WebSocket server on this loopback port (off by default); "
        "other computers connect through ws://HOST:PORT/foxglove?token=API_TOKEN",
    )
    serve.add_argument("--seed", type=int, default=None, help="world seed (object placement, obstacles)")
    serve.add_argument("--no-mirror", action="store_true", help="do not start the 3D mirror")
    serve.add_argument(
        "--tls",
        action="store_true",
        help="HTTPS with this robot's own certificate, made once in the data directory (the microphone of a page on "
        "another computer needs HTTPS)",
    )
    serve.add_argument("--tls-cert", default=None, help="HTTPS with this certificate (PEM; with --tls-key)")
    serve.add_argument("--tls-key", default=None, help="the certificate's private key (PEM)")
    serve.set_defaults(func=_serve)

    run = sub.add_parser("run", help="run one command headless in simulation and print the result")
    run.add_argument("text", nargs="?", default="", help='e.g. "pick up the red mug from the kitchen counter"')
    run.add_argument("--audio", default=None, help="a spoken command (WAV; other formats with PyAV) instead of text")
    run.add_argument("--seed", type=int, default=0)
    run.add_argument("--json", action="store_true", help="print the result as JSON")
    run.add_argument("--timeout", type=float, default=300.0, help="wall-clock limit in seconds")
    run.add_argument(
        "--backend",
        choices=["sim", "hil"],
        default="sim",
        help="sim (the simulation, as fast as it goes) or hil (the real-robot backend driving the simulated robot "
        "through the hardware-in-the-loop rig, in lockstep; sim_time_s is the rig's physics time)",
    )
    run.set_defaults(func=_run)

    transcribe = sub.add_parser("transcribe", help="speech to text, with the world's names as hints")
    transcribe.add_argument("file", help="a WAV file (other formats with PyAV)")
    transcribe.add_argument(
        "--engine",
        choices=["auto", "pocketsphinx", "whisper"],
        default=None,
        help="recogniser (default: HUMANOID_ASR_ENGINE, else auto: whisper when installed, else pocketsphinx)",
    )
    transcribe.add_argument("--seed", type=int, default=0, help="world seed (its objects and places are listened for)")
    transcribe.add_argument(
        "--json", action="store_true", help='print {"text": ..., "confidence": ..., "stop_word": ...}'
    )
    transcribe.set_defaults(func=_transcribe)

    plan = sub.add_parser("plan", help="print the validated plan for a command, without moving the robot")
    plan.add_argument("text", help='e.g. "bring the red mug to the living-room table"')
    plan.add_argument(
        "--backend",
        choices=["rules", "openai", "local"],
        default=None,
        help="planner backend (default: HUMANOID_PLANNER_BACKEND, else rules)",
    )
    plan.add_argument("--seed", type=int, default=0, help="world seed (which places and objects exist)")
    plan.add_argument("--holding", default=None, help="plan as if the robot held this object")
    plan.add_argument(
        "--json",
        action="store_true",
        help='print the plan as a JSON list of actions (or {"clarify": QUESTION} when it must ask)',
    )
    plan.set_defaults(func=_plan)

    estop = sub.add_parser("estop", help="latch (or --release) the e-stop of a running server")
    estop.add_argument("--release", action="store_true")
    estop.add_argument("--url", default=None, help="server URL (default http://HOST:PORT)")
    estop.set_defaults(func=_estop)

    describe = sub.add_parser("describe", help="the robot's description: its joints, or its URDF (--urdf)")
    describe.add_argument("--urdf", action="store_true", help="the URDF generated from the simulator's model")
    describe.add_argument("-o", "--output", default=None, help="write to this file (default: standard output)")
    describe.set_defaults(func=_describe)

    add_sessions_parser(sub)
    add_hardware_parser(sub)
    add_hil_parser(sub)
    add_users_parser(sub)

    add_db_parser(sub)
    add_service_parser(sub)
    add_doctor_parser(sub)

    behaviours = sub.add_parser("behaviours", help="list the installed behaviours, or run one headless")
    behaviour_sub = behaviours.add_subparsers(dest="behaviours_command", required=True)
    listing = behaviour_sub.add_parser("list", help="every behaviour: name, description, parameters")
    listing.add_argument("--json", action="store_true", help="print the list as JSON")
    listing.set_defaults(func=_behaviours_list)
    running = behaviour_sub.add_parser("run", help="run one behaviour headless in simulation, recorded as a session")
    running.add_argument("name", help="e.g. patrol, tour, fetch, demo")
    running.add_argument("--seed", type=int, default=0)
    running.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="a parameter (repeat for more), e.g. --set laps=2 --set waypoints=dock,table",
    )
    running.add_argument("--json", action="store_true", help="print the result as JSON")
    running.add_argument("--timeout", type=float, default=1800.0, help="wall-clock limit in seconds")
    running.set_defaults(func=_behaviours_run)

    bench = sub.add_parser("bench", help="benchmarks, written as JSON")
    suites = [
        "core",
        "load",
        "walk",
        "perception",
        "capstone",
        "planner",
        "language",
        "voice",
        "speech",
        "sessions",
        "diagnostics",
        "dynamixel",
        "network",
        "behaviours",
    ]
    bench.add_argument("suite", choices=suites)
    bench.add_argument("--json", action="store_true", help="print the JSON result")
    bench.add_argument("--output", default=None, help="also write the JSON result to this file")
    bench.add_argument("--presses", type=int, default=100, help="e-stop presses to time")
    bench.add_argument(
        "--viewers",
        type=int,
        default=None,
        help="core: browser pages with the 3D view open (2); load: viewers connected (20)",
    )
    bench.add_argument(
        "--duration",
        type=float,
        default=None,
        help="core: seconds of control-loop timing (>= 30 s: the tick window); sessions: seconds per phase; "
        "diagnostics: seconds of monitoring measured (60); dynamixel: seconds per phase (10); network: seconds each "
        "viewer is measured (20); default 30",
    )
    bench.add_argument("--session-minutes", type=float, default=10.0, help="sessions: length of the long session")
    bench.add_argument("--scripts", type=int, default=20, help="walk: random velocity scripts to run")
    bench.add_argument(
        "--backend",
        choices=["sim", "hil"],
        default="sim",
        help="walk: sim (the simulation's own loop) or hil (the real-robot backend through the hardware-in-the-loop "
        "rig, one script at a time); core: hil times the e-stop from the page to the servo bus, the console served "
        "as the real robot on the rig in real time",
    )
    bench.add_argument(
        "--lockstep",
        action="store_true",
        help="walk --backend hil: the rig's physics moves one control period per tick (not with the wall clock)",
    )
    bench.add_argument("--script-duration", type=float, default=60.0, help="walk: seconds per script")
    bench.add_argument("--seed", type=int, default=0, help="walk, perception: first seed; network: the link's losses")
    bench.add_argument("--cuts", type=int, default=6, help="network: link cuts while driving")
    bench.add_argument(
        "--realtime-duration",
        type=float,
        default=30.0,
        help="walk, perception: seconds of real-time walking for the tick and rate figures",
    )
    bench.add_argument(
        "--seeds",
        type=int,
        default=None,
        help="perception: worlds to place the robot in (50); capstone: worlds per task (30); behaviours: worlds per "
        "behaviour and set (10)",
    )
    bench.add_argument(
        "--tasks", default="pick,bring,blocked", help="capstone: which tasks (pick, bring, blocked), comma-separated"
    )
    bench.add_argument(
        "--jobs", type=int, default=1, help="capstone, behaviours: runs at once (1 measures wall time fairly)"
    )
    bench.add_argument(
        "--behaviours", default=None, help="behaviours: which (patrol, tour, fetch, demo), comma-separated; default all"
    )
    bench.add_argument(
        "--heldout-seed", type=int, default=100, help="behaviours: first seed of the held-out set (as many as --seeds)"
    )
    bench.add_argument("--no-heldout", action="store_true", help="behaviours: the development seeds only")
    bench.add_argument("--views", type=int, default=6, help="perception: viewpoints per world")
    bench.add_argument("--tours", type=int, default=5, help="perception: mapping tours (one world each)")
    bench.add_argument(
        "--backends",
        default=None,
        help="planner, language: backends to measure, comma-separated (rules, openai, local); default rules "
        "(planner), rules and every configured LLM backend (language)",
    )
    bench.add_argument("--repeat", type=int, default=1, help="planner: times each command is planned")
    bench.add_argument(
        "--no-fallback", action="store_true", help="planner, language: judge an LLM backend alone (no rules fallback)"
    )
    bench.add_argument(
        "--sets",
        default="all",
        help="speech: spoken sets (dev, heldout, heldout2 ...), comma-separated; all of them unless told",
    )
    bench.add_argument(
        "--whisper-model",
        default="",
        help="speech: a CTranslate2 whisper model directory to measure instead of the packaged tiny.en",
    )
    bench.add_argument(
        "--whisper-second-model",
        default="auto",
        help="speech: the model that hears again what the first is not sure of (auto: the packaged base; off: none; "
        "or a directory)",
    )
    bench.add_argument(
        "--engines",
        default="whisper,pocketsphinx",
        help="speech, language: recognisers (whisper, pocketsphinx), comma-separated",
    )
    bench.add_argument(
        "--spoken",
        default="",
        help="language: spoken sets (dev, heldout, heldout2 ...) to measure too, per recogniser and planner; none "
        "unless told (about 9 min a set with whisper)",
    )
    bench.add_argument(
        "--no-robot-microphone", action="store_true", help="speech: leave out the robot microphone's stop timing"
    )
    bench.add_argument(
        "--quick",
        action="store_true",
        help="voice, speech, language (spoken): a few utterances, one voice, clean only (shows the bench works; "
        "its figures mean little)",
    )
    bench.set_defaults(func=_bench)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "seed", None) is not None and args.seed < 0:
        parser.error("--seed must be >= 0")
    return args.func(args, get_settings())


if __name__ == "__main__":
    sys.exit(main())
