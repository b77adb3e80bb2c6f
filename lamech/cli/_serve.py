"""``lamech serve``: a local page to edit a problem, check it as you type, and solve or
simulate it, the report shown beside the editor.

Built on Starlette (routing, requests, JSON) and served by uvicorn: no HTTP is written
here. Loopback only by default. Every piece of work on user text (loading, solving,
simulating, drawing) runs in a child process with a time bound (``--timeout``): SymPy
cannot be interrupted inside a server thread, but a process can be killed, and a
hostile expression then costs one process, not the server. Requests over
:data:`MAX_BODY` bytes are refused before they are read. User text is only ever parsed
by lamech's own expression parser (never ``eval``); errors come back as the CLI says
them, with their line in the file.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import sys
import threading
import time
from pathlib import Path
from typing import Any

__all__ = ["add_parser", "run", "make_app"]

MAX_BODY = 1_000_000
"""The largest request body accepted (bytes): the loader's limit for a problem file."""
DEFAULT_TIMEOUT = 60.0
MAX_T_END = 1000.0
PAGE = Path(__file__).resolve().parent.parent / "present" / "app.html"


def add_parser(subparsers) -> argparse.ArgumentParser:
    s = subparsers.add_parser(
        "serve",
        help="a local page: edit a problem (checked as you type), solve or simulate it, "
        "see the report",
        description="Serve a local page (Starlette on uvicorn) to edit a problem file with "
        "live checking (errors at their line), pick a bundled example, and solve or "
        "simulate it, the report page shown beside the editor. Listens on the loopback "
        "interface only unless --host says otherwise. Each request's work runs in a child "
        "process bounded by --timeout.",
    )
    s.add_argument("--host", default="127.0.0.1", help="interface (default %(default)s)")
    s.add_argument("--port", type=int, default=8765, help="port (default %(default)s)")
    s.add_argument(
        "--timeout",
        type=float,
        default=DEFAULT_TIMEOUT,
        help="seconds one request's work may take (default %(default)s)",
    )
    return s


# ----- the work, in a child process ----------------------------------------------------
def _errors(exc: BaseException) -> list[dict]:
    problems = getattr(exc, "problems", None)
    if problems:
        return [
            {"line": p.line, "where": p.where, "message": p.message, "text": p.text}
            for p in problems
        ]
    return [{"line": None, "where": "", "message": str(exc), "text": None}]


def _work(kind: str, text: str, options: dict) -> dict:
    """Check, or solve (and simulate) the problem ``text``: a JSON-able answer."""
    import matplotlib

    matplotlib.use("Agg")
    from ..model import ModelError
    from ..numeric import SimulationError, simulate
    from ..present import report_page
    from ..problem import ProblemFileError, loads
    from ..symbolic import DegenerateConstraintsError, solve, steps

    try:
        system = loads(text, name="problem.toml")
        if kind == "check":
            return {"ok": True, "title": system.title}
        sol = solve(system)
        derivation = steps(sol)
    except (ProblemFileError, DegenerateConstraintsError, ModelError, ValueError) as exc:
        return {"ok": False, "errors": _errors(exc)}
    traj, note = None, ""
    if options.get("simulate"):
        try:
            traj = simulate(system, float(options["t_end"]))
        except SimulationError as exc:
            note = f"no simulation: {exc}"
    lift = [
        {
            "constraint": k,
            "coordinate": r[0].coordinate,
            "value": r[0].value,
            "degrees": r[0].degrees,
        }
        for k, r in sol.vanishes.items()
        if r
    ]
    return {
        "ok": True,
        "title": system.title,
        "page": report_page(sol, derivation, text, traj, None, note),
        "lets_go": lift,
        "status": None if traj is None else traj.status,
    }


MAX_CASES = 10_000
"""The largest sweep the page runs (a terminal's `lamech sweep` has no such bound)."""


def _sweep(conn, text: str, options: dict) -> dict:
    """Run a sweep in this (child) process, sending ("progress", done, total) as cases
    finish: the table and the plot as HTML."""
    import matplotlib

    matplotlib.use("Agg")
    from ..present import sweep_html
    from ..problem import ProblemFileError, loads
    from ..sweeps import SweepError, run_sweep

    try:
        system = loads(text, name="problem.toml")
        run = run_sweep(
            system,
            options["params"],
            options["measures"],
            t_end=options["t_end"],
            workers=1,  # this process is the worker: a daemon process has no children
            samples=201,
            progress=lambda done, total: conn.send(("progress", done, total)),
        )
    except (ProblemFileError, SweepError, ValueError) as exc:
        return {"ok": False, "errors": _errors(exc)}
    return {"ok": True, "html": sweep_html(run), "counts": run.counts}


def _child(conn, kind: str, text: str, options: dict) -> None:
    try:
        if kind == "sweep":
            conn.send(("done", _sweep(conn, text, options)))
            return
        conn.send(_work(kind, text, options))
    except BaseException as exc:  # noqa: BLE001 - whatever it is, say it, not a hang
        conn.send({"ok": False, "errors": _errors(RuntimeError(f"internal error: {exc!r}"))})
    finally:
        conn.close()


class Runner:
    """Runs :func:`_work` in child processes (from a fork server with lamech loaded), at
    most ``slots`` at once, each killed past ``timeout`` seconds."""

    def __init__(self, timeout: float, slots: int = 2):
        self.timeout = timeout
        self.slots = threading.BoundedSemaphore(slots)
        self.ctx: Any
        try:
            self.ctx = mp.get_context("forkserver")
            self.ctx.set_forkserver_preload(["lamech.cli._serve", "lamech.symbolic"])
        except ValueError:  # pragma: no cover - no fork server on this platform
            self.ctx = mp.get_context("spawn")

    def sweep(self, text: str, options: dict, job: dict) -> None:
        """Run a sweep, ``job`` updated as it goes (``done``, ``total``), then with the
        answer (``finished``); bounded by ten times the timeout."""
        bound = 10 * self.timeout
        with self.slots:
            here, there = self.ctx.Pipe(duplex=False)
            proc = self.ctx.Process(
                target=_child, args=(there, "sweep", text, options), daemon=True
            )
            started = time.perf_counter()
            proc.start()
            there.close()
            answer = None
            try:
                while answer is None:
                    left = bound - (time.perf_counter() - started)
                    if left <= 0 or not here.poll(left):
                        answer = {
                            "ok": False,
                            "errors": _errors(
                                TimeoutError(
                                    f"the sweep was stopped after {bound:g} s (ten times the "
                                    "server's --timeout); run it with `lamech sweep` in a "
                                    "terminal, which has no bound and can resume"
                                )
                            ),
                        }
                        break
                    try:
                        msg = here.recv()
                    except EOFError:
                        answer = {"ok": False, "errors": _errors(RuntimeError("the sweep died"))}
                        break
                    if isinstance(msg, tuple) and msg[0] == "progress":
                        job["done"], job["total"] = msg[1], msg[2]
                    elif isinstance(msg, tuple) and msg[0] == "done":
                        answer = msg[1]
                    else:  # an internal error reported by _child
                        answer = msg
            finally:
                if proc.is_alive():
                    proc.kill()
                proc.join(5)
                here.close()
            answer["seconds"] = round(time.perf_counter() - started, 3)
            job.update(answer)
            job["finished"] = True

    def __call__(self, kind: str, text: str, options: dict) -> dict:
        with self.slots:
            here, there = self.ctx.Pipe(duplex=False)
            proc = self.ctx.Process(target=_child, args=(there, kind, text, options), daemon=True)
            started = time.perf_counter()
            proc.start()
            there.close()
            try:
                if here.poll(self.timeout):
                    try:
                        answer = here.recv()
                    except EOFError:
                        answer = None
                else:
                    answer = {
                        "ok": False,
                        "errors": _errors(
                            TimeoutError(
                                f"stopped after {self.timeout:g} s (the server's --timeout): "
                                "the problem is too large or an expression too hard to "
                                "simplify; try `lamech solve` in a terminal"
                            )
                        ),
                    }
            finally:
                if proc.is_alive():
                    proc.kill()
                proc.join(5)
                here.close()
            if answer is None:
                answer = {
                    "ok": False,
                    "errors": _errors(RuntimeError("the worker ended without an answer")),
                }
            answer["seconds"] = round(time.perf_counter() - started, 3)
            return answer


# ----- the web app ----------------------------------------------------------------------
def make_app(timeout: float = DEFAULT_TIMEOUT):
    """The Starlette application (also what the tests drive)."""
    from starlette.applications import Starlette
    from starlette.concurrency import run_in_threadpool
    from starlette.requests import Request
    from starlette.responses import HTMLResponse, JSONResponse, PlainTextResponse
    from starlette.routing import Route

    from ..problem import example_names, example_path, example_title

    runner = Runner(timeout)

    def refuse(status: int, message: str) -> JSONResponse:
        return JSONResponse({"ok": False, "errors": _errors(ValueError(message))}, status)

    async def body(request: Request) -> tuple[dict | None, JSONResponse | None]:
        size = request.headers.get("content-length")
        if size is None or not size.isdigit():
            return None, refuse(411, "a request needs a Content-Length")
        if int(size) > MAX_BODY:
            return None, refuse(413, f"the problem is over {MAX_BODY // 1000} kB")
        raw = await request.body()
        if len(raw) > MAX_BODY:
            return None, refuse(413, f"the problem is over {MAX_BODY // 1000} kB")
        try:
            import json

            data = json.loads(raw)
        except ValueError:
            return None, refuse(400, "the request is not JSON")
        if not isinstance(data, dict) or not isinstance(data.get("text"), str):
            return None, refuse(400, 'the request needs "text": the problem file')
        return data, None

    async def home(request: Request) -> HTMLResponse:
        return HTMLResponse(PAGE.read_text(encoding="utf-8"))

    async def examples(request: Request) -> JSONResponse:
        return JSONResponse([{"name": n, "title": example_title(n)} for n in example_names()])

    async def example(request: Request) -> Any:
        name = request.path_params["name"]
        if name not in example_names():
            return PlainTextResponse(f"no bundled example {name!r}", 404)
        return PlainTextResponse(example_path(name).read_text(encoding="utf-8"))

    async def check(request: Request) -> JSONResponse:
        data, bad = await body(request)
        if bad is not None:
            return bad
        assert data is not None
        return JSONResponse(await run_in_threadpool(runner, "check", data["text"], {}))

    async def solve(request: Request) -> JSONResponse:
        data, bad = await body(request)
        if bad is not None:
            return bad
        assert data is not None
        simulate = bool(data.get("simulate"))
        t_end = data.get("t_end", 3.0)
        if simulate and (
            isinstance(t_end, bool)
            or not isinstance(t_end, (int, float))
            or not 0 < t_end <= MAX_T_END
        ):
            return refuse(400, f"t_end must be a number in (0, {MAX_T_END:g}] seconds")
        options = {"simulate": simulate, "t_end": float(t_end) if simulate else None}
        return JSONResponse(await run_in_threadpool(runner, "run", data["text"], options))

    jobs: dict[str, dict] = {}

    def grid_size(params: dict) -> int:
        size = 1
        for name, v in params.items():
            if isinstance(v, str) and v.count(":") == 2:
                n = v.rsplit(":", 1)[1].strip()
                if not n.isdigit():
                    raise ValueError(f"{name}: A:B:N needs a whole number N, got {n!r}")
                size *= int(n)
            elif isinstance(v, str):
                size *= len(v.split(","))
            elif isinstance(v, list):
                size *= len(v)
            else:
                raise ValueError(f'{name}: give "A:B:N", "a,b,c" or a list of numbers')
        return size

    async def sweep(request: Request) -> JSONResponse:
        data, bad = await body(request)
        if bad is not None:
            return bad
        assert data is not None
        params, measures, t_end = data.get("params"), data.get("measures"), data.get("t_end")
        if not isinstance(params, dict) or not params:
            return refuse(400, 'a sweep needs "params": {name: "A:B:N" or "a,b,c"}')
        if not isinstance(measures, list) or not all(isinstance(m, str) for m in measures):
            return refuse(400, 'a sweep needs "measures": a list such as ["liftoff"]')
        if isinstance(t_end, bool) or not isinstance(t_end, (int, float)):
            return refuse(400, f"t_end must be a number in (0, {MAX_T_END:g}] seconds")
        if not 0 < t_end <= MAX_T_END:
            return refuse(400, f"t_end must be a number in (0, {MAX_T_END:g}] seconds")
        try:
            size = grid_size(params)
        except ValueError as exc:
            return refuse(400, str(exc))
        if size > MAX_CASES:
            return refuse(
                400, f"{size} cases: the page runs at most {MAX_CASES}; use `lamech sweep`"
            )
        import uuid

        key = uuid.uuid4().hex
        job = {"done": 0, "total": size, "finished": False}
        finished = [k for k, j in jobs.items() if j.get("finished")]
        for old in finished[: max(0, len(finished) - 50)]:  # keep the last 50 answers
            del jobs[old]
        jobs[key] = job
        options = {"params": params, "measures": measures, "t_end": float(t_end)}
        threading.Thread(
            target=runner.sweep, args=(data["text"], options, job), daemon=True
        ).start()
        return JSONResponse({"ok": True, "job": key, "total": size})

    async def sweep_status(request: Request) -> JSONResponse:
        job = jobs.get(request.path_params["job"])
        if job is None:
            return refuse(404, "no such sweep")
        return JSONResponse(job)

    return Starlette(
        routes=[
            Route("/api/sweep", sweep, methods=["POST"]),
            Route("/api/sweep/{job}", sweep_status),
            Route("/", home),
            Route("/api/examples", examples),
            Route("/api/examples/{name}", example),
            Route("/api/check", check, methods=["POST"]),
            Route("/api/run", solve, methods=["POST"]),
        ]
    )


def run(args: argparse.Namespace) -> int:
    try:
        import uvicorn
    except ImportError:
        print(
            "lamech: serve needs starlette and uvicorn: pip install 'lamech[serve]' "
            "(./run installs them)",
            file=sys.stderr,
        )
        return 2
    if not args.timeout > 0:
        print("lamech: --timeout must be positive", file=sys.stderr)
        return 2
    if args.host not in ("127.0.0.1", "localhost", "::1"):
        print(
            f"lamech: warning: serving on {args.host}: anyone who can reach it can run "
            "problems on this machine",
            file=sys.stderr,
        )
    print(f"lamech: serving on http://{args.host}:{args.port}/ (Ctrl-C stops)", file=sys.stderr)
    uvicorn.run(make_app(args.timeout), host=args.host, port=args.port, log_level="warning")
    return 0
