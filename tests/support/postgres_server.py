"""A throwaway PostgreSQL server for tests, from Debian's `postgresql` package (no system service is used): initdb in
a temporary directory, the server on a free loopback port, removed afterwards. As root, initdb and the server run
as the `postgres` user (they refuse root). A server whose test run was killed dies with it (PDEATHSIG), and its
directory is swept by the next run."""

from __future__ import annotations

import contextlib
import ctypes
import fcntl
import glob
import os
import shutil
import signal
import subprocess
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from harness.server import free_port

STARTUP_TIMEOUT_S = 30.0


class PostgresUnavailable(RuntimeError):
    pass


def postgres_bin_dir() -> Path:
    found = glob.glob("/usr/lib/postgresql/*/bin/initdb")
    if found:
        return Path(max(found, key=lambda p: int(p.split("/")[4]))).parent
    initdb = shutil.which("initdb")
    if initdb:
        return Path(initdb).parent
    raise PostgresUnavailable("PostgreSQL's server is not installed (apt-get install -y postgresql)")


def _die_with_parent() -> None:
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGQUIT)  # PR_SET_PDEATHSIG


def _sweep_stale(min_age_s: float = 60.0) -> None:
    for folder in glob.glob("/tmp/pgtest-*"):
        try:
            if time.time() - os.path.getmtime(folder) < min_age_s:
                continue
            with open(os.path.join(folder, "owner.lock"), "a") as lock:
                fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            continue  # its owner still runs
        shutil.rmtree(folder, ignore_errors=True)


@contextlib.contextmanager
def postgres_server(database: str = "test") -> Iterator[str]:
    """Yields a SQLAlchemy URL (psycopg 3) of an empty database on a fresh server."""
    bin_dir = postgres_bin_dir()
    _sweep_stale()
    folder = tempfile.mkdtemp(prefix="pgtest-", dir="/tmp")  # reachable by the postgres user
    lock = open(os.path.join(folder, "owner.lock"), "w")  # noqa: SIM115 (held for the server's lifetime)
    fcntl.flock(lock, fcntl.LOCK_EX)
    as_user: dict = {}
    if os.geteuid() == 0:
        shutil.chown(folder, "postgres", "postgres")
        as_user = {"user": "postgres", "group": "postgres", "extra_groups": []}
    data = os.path.join(folder, "data")
    log = open(os.path.join(folder, "postgres.log"), "wb")  # noqa: SIM115
    process: subprocess.Popen | None = None
    try:
        initdb = [
            str(bin_dir / "initdb"),
            "-D",
            data,
            "-U",
            "postgres",
            "-A",
            "trust",
            "-E",
            "UTF8",
            "--locale=C",
            "--no-sync",
        ]
        subprocess.run(initdb, check=True, stdout=subprocess.DEVNULL, stderr=log, **as_user)
        port = 0
        for _ in range(5):  # another process may take the free port first
            port = free_port()
            process = subprocess.Popen(
                [
                    str(bin_dir / "postgres"),
                    "-D",
                    data,
                    "-h",
                    "127.0.0.1",
                    "-p",
                    str(port),
                    "-k",
                    folder,
                    "-c",
                    "fsync=off",
                    "-c",
                    "synchronous_commit=off",
                    "-c",
                    "full_page_writes=off",
                    "-c",
                    "shared_buffers=32MB",
                    "-c",
                    "max_connections=50",
                ],
                stdout=log,
                stderr=log,
                preexec_fn=_die_with_parent,
                start_new_session=True,
                **as_user,
            )
            deadline = time.monotonic() + STARTUP_TIMEOUT_S
            while process.poll() is None and time.monotonic() < deadline:
                ready = subprocess.run([str(bin_dir / "pg_isready"), "-q", "-h", "127.0.0.1", "-p", str(port)])
                if ready.returncode == 0:
                    break
                time.sleep(0.05)
            if process.poll() is None:
                break
        if process is None or process.poll() is not None:
            log.flush()
            raise PostgresUnavailable("postgres did not start:\n" + Path(log.name).read_text()[-2000:])
        subprocess.run(
            [str(bin_dir / "createdb"), "-h", "127.0.0.1", "-p", str(port), "-U", "postgres", database], check=True
        )
        yield f"postgresql+psycopg://postgres@127.0.0.1:{port}/{database}"
    finally:
        if process is not None and process.poll() is None:
            process.send_signal(signal.SIGINT)  # fast shutdown
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        log.close()
        lock.close()
        shutil.rmtree(folder, ignore_errors=True)
