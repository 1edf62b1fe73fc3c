"""`humanoid bench SUITE`: measured figures written as JSON (targets live here, never in timed unit tests)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def run_suite(suite: str, args: argparse.Namespace) -> int:
    if suite == "core" and args.backend == "hil":
        from bench.hil_estop import run_hil_estop

        result = run_hil_estop(presses=args.presses, duration_s=args.duration or 30.0, seed=args.seed or 0)
    elif suite == "core":
        from bench.core import run_core

        result = run_core(presses=args.presses, viewers=args.viewers or 2, duration_s=args.duration or 30.0)
    elif suite == "load":
        from bench.load import run_load

        result = run_load(viewers=args.viewers or 20, presses=args.presses)
    elif suite == "walk" and args.backend == "hil":
        from bench.hil import run_hil_walk

        result = run_hil_walk(
            scripts=args.scripts, duration_s=args.script_duration, seed=args.seed or 0, lockstep=args.lockstep
        )
    elif suite == "walk":
        from bench.walk import run_walk

        result = run_walk(
            scripts=args.scripts,
            duration_s=args.script_duration,
            seed=args.seed or 0,
            realtime_s=args.realtime_duration,
        )
    elif suite == "perception":
        from bench.perception import run_perception

        result = run_perception(
            seeds=args.seeds or 50,
            views=args.views,
            seed=args.seed or 0,
            realtime_s=args.realtime_duration,
            tours=args.tours,
        )
    elif suite == "capstone":
        from bench.capstone import TASKS, run_capstone

        tasks = tuple(t.strip() for t in args.tasks.split(",") if t.strip())
        unknown = [t for t in tasks if t not in TASKS]
        if unknown or not tasks:
            choices = ", ".join(TASKS)
            print(f"unknown capstone task(s) {unknown or args.tasks!r}: choose from {choices}", file=sys.stderr)
            return 2
        result = run_capstone(seeds=args.seeds or 30, seed=args.seed or 0, tasks=tasks, jobs=args.jobs)
    elif suite == "behaviours":
        from bench.behaviours import BEHAVIOURS, run_behaviours_bench

        chosen = tuple(b.strip() for b in (args.behaviours or ",".join(BEHAVIOURS)).split(",") if b.strip())
        unknown = [b for b in chosen if b not in BEHAVIOURS]
        if unknown or not chosen:
            print(f"unknown behaviour(s) {unknown or chosen!r}: choose from {', '.join(BEHAVIOURS)}", file=sys.stderr)
            return 2
        heldout = None if args.no_heldout else args.heldout_seed
        result = run_behaviours_bench(
            seeds=args.seeds or 10, seed=args.seed or 0, behaviours=chosen, jobs=args.jobs, heldout_seed=heldout
        )
    elif suite == "speech":
        from bench.spoken import run_speech
        from harness.spoken_cases import SETS

        sets = tuple(SETS) if args.sets == "all" else tuple(s.strip() for s in args.sets.split(",") if s.strip())
        unknown = [name for name in sets if name not in SETS]
        if unknown:
            raise SystemExit(f"unknown spoken set(s) {', '.join(unknown)}; known: {', '.join(SETS)}")
        engines = tuple(e.strip() for e in args.engines.split(",") if e.strip())
        result = run_speech(
            sets=sets,
            engines=engines,
            robot_microphone=not args.no_robot_microphone,
            quick=args.quick,
            whisper_model=args.whisper_model,
            whisper_second_model=args.whisper_second_model,
        )
    elif suite == "planner":
        from app.settings import get_settings
        from bench.planner import parse_backends, run_planner

        try:
            backends = parse_backends(args.backends or "rules")
        except ValueError as exc:
            print(exc, file=sys.stderr)
            return 2
        result = run_planner(get_settings(), backends, repeat=args.repeat, no_fallback=args.no_fallback)
    elif suite == "language":
        from app.settings import get_settings
        from bench.language import run_language
        from bench.planner import parse_backends

        try:
            backends = parse_backends(args.backends) if args.backends else None
        except ValueError as exc:
            print(exc, file=sys.stderr)
            return 2
        from harness.spoken_cases import SETS

        spoken = tuple(s.strip() for s in (args.spoken or "").split(",") if s.strip())
        unknown = [name for name in spoken if name not in SETS]
        if unknown:
            raise SystemExit(f"unknown spoken set(s) {', '.join(unknown)}; known: {', '.join(SETS)}")
        engines = tuple(e.strip() for e in args.engines.split(",") if e.strip())
        result = run_language(get_settings(), backends, args.no_fallback, spoken, engines, args.quick)
    elif suite == "sessions":
        from bench.sessions import run_sessions

        result = run_sessions(phase_s=args.duration or 30.0, session_minutes=args.session_minutes)
    elif suite == "dynamixel":
        from bench.dynamixel import run_dynamixel

        result = run_dynamixel(seconds=args.duration or 10.0)
    elif suite == "diagnostics":
        from bench.diagnostics import run_diagnostics

        result = run_diagnostics(duration_s=args.duration or 60.0)
    elif suite == "network":
        from bench.network import run_network

        result = run_network(
            presses=args.presses, cuts=args.cuts, viewer_seconds=args.duration or 20.0, seed=args.seed or 0
        )
    elif suite == "voice":
        from bench.voice import run_voice

        result = run_voice(quick=args.quick)
    else:  # pragma: no cover - argparse restricts the choices
        raise SystemExit(f"unknown suite {suite}")
    text = json.dumps(result, indent=2)
    if args.output:
        Path(args.output).parent.mkdir(parents=True, exist_ok=True)
        Path(args.output).write_text(text + "\n")
    if args.json or not args.output:
        print(text)
    else:
        print(f"wrote {args.output}", file=sys.stderr)
    return 0
