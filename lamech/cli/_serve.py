"""``lamech serve``: a local page to edit a problem, check it as you type, and solve or
simulate it, the report shown beside the editor.

Built on Starlette (routing, requests, JSON) and served by uvicorn: no HTTP is written
here. Safe to leave running, as Jupyter's server is: loopback only (:func:`host_refusal`), a token
(random unless ``--token`` gives one, printed in the URL at start), the Host and Origin
checked and work taken as JSON only (:mod:`lamech.cli._guard`); every answer with a
Content-Security-Policy and no referrer (:mod:`lamech.cli._headers`), the page's policy
allowing its own scripts by a nonce drawn per answer. Every piece of work on
user text runs in a child process bounded by ``--timeout``, in a few slots with a
bounded queue (503 and ``Retry-After`` when full), killed when its client goes away;
checks have their own slots, so a check is answered while slow solves run; SIGINT and
SIGTERM end every child and stop the server within seconds (:mod:`lamech.cli._workers`).
Requests over :data:`MAX_BODY` bytes are refused before they are read; every malformed
request is a 4xx with a message; a client that hangs up in the middle of its request
costs one line in the log. Each child's address space is bounded (``--memory``,
:data:`DEFAULT_MEMORY_GB`): a problem that would fill the machine's memory ends its
own process with a message. User text is only ever parsed by lamech's own
expression parser (never ``eval``), and names no files (it has no folder).
"""

from __future__ import annotations

import argparse
import json
import math
import secrets
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import asyncio

__all__ = ["add_parser", "run", "make_app", "host_refusal", "DEFAULT_MEMORY_GB"]

MAX_BODY = 1_000_000
"""The largest request body accepted (bytes): the loader's limit for a problem file."""
DEFAULT_TIMEOUT = 60.0
CHECK_TIMEOUT = 10.0
"""The most seconds a check (load and validate, as one types) may take."""
MAX_T_END = 1000.0
MAX_CASES = 10_000
"""The largest sweep the page runs (a terminal's `lamech sweep` has no such bound)."""
SLOTS, QUEUE = 2, 4
"""Solves, simulations and sweeps at once, and how many more may wait."""
CHECK_SLOTS, CHECK_QUEUE = 1, 8
RETRY_AFTER = 5
DEFAULT_MEMORY_GB = 4.0
"""The address space (virtual memory) each child process may take, in GB (10^9 bytes):
a solve and simulation of the bundled examples peaks at 0.63 GB of address space
(0.27 GB resident), a C compile beside it (which inherits the limit) under 0.7 GB."""
LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "::1")
"""The only interfaces ``--host`` may name: see :func:`host_refusal`."""
SWEEP_IDLE = 30.0
"""A sweep whose page has not asked for it in this many seconds is cancelled."""
PAGE = Path(__file__).resolve().parent.parent / "present" / "app.html"


def add_parser(subparsers) -> argparse.ArgumentParser:
    s = subparsers.add_parser(
        "serve",
        help="a local page: edit a problem (checked as you type), solve or simulate it, "
        "see the report",
        description="Serve a local page (Starlette on uvicorn) to edit a problem file with "
        "live checking (errors at their line), pick a bundled example, and solve or "
        "simulate it, the report page shown beside the editor. Listens on the loopback "
        "interface only unless --host says otherwise, and answers only requests that "
        "carry its token (open the URL it prints). Each request's work runs in a child "
        "process bounded by --timeout.",
    )
    s.add_argument(
        "--host",
        default="127.0.0.1",
        help="the loopback interface to listen on: 127.0.0.1, localhost or ::1 (default "
        "%(default)s); to use the page from another machine, forward the port over SSH",
    )
    s.add_argument("--port", type=int, default=8765, help="port (default %(default)s)")
    s.add_argument(
        "--token",
        default=None,
        help="the token a request must carry (Authorization: token TEXT, or ?token=TEXT "
        "in the URL); default: a random one, printed in the URL at start",
    )
    s.add_argument(
        "--timeout",
        type=float,
        default=DEFAULT_TIMEOUT,
        help="seconds one request's work may take (default %(default)s)",
    )
    s.add_argument(
        "--memory",
        type=float,
        default=DEFAULT_MEMORY_GB,
        metavar="GB",
        help="the address space (virtual memory) one request's process may take, in GB "
        f"(default {DEFAULT_MEMORY_GB:g}); past it the work ends with a message",
    )
    return s


def host_refusal(host: str) -> str | None:
    """Why ``lamech serve`` will not listen on ``host``, or None for a loopback name.

    Any other interface is refused rather than half supported. The page runs problems
    (user text, SymPy, compiled code) on this machine for anyone who holds the token; it
    has no TLS, so the token would cross the network in clear text; and its Host check
    knows the loopback names only (a DNS-rebinding page is refused by it). Remote use
    done properly needs an allow-list of host names, TLS and a long token (Jupyter's
    ``allow_remote_access``); an SSH tunnel gives all three today, with nothing new to
    get wrong here.
    """
    if host in LOOPBACK_HOSTS:
        return None
    return (
        f"--host {host}: lamech serve listens on the loopback interface only "
        f"({', '.join(LOOPBACK_HOSTS)}): the page runs problems on this machine for anyone "
        "who has its token, and it has no TLS. To use it from another machine, forward "
        "the port over SSH: ssh -L 8765:127.0.0.1:8765 THIS-MACHINE, then open the URL "
        "it prints there"
    )


def _json_response():
    """Starlette's JSONResponse, written in ASCII (``\\u`` escapes): whatever the text of
    an answer, it encodes."""
    from starlette.responses import JSONResponse

    class AsciiJSON(JSONResponse):
        def render(self, content: Any) -> bytes:
            try:
                return json.dumps(content, ensure_ascii=True, allow_nan=False).encode("ascii")
            except ValueError:  # a NaN or infinity: null, as JSON has no such number
                return json.dumps(_finite(content), ensure_ascii=True).encode("ascii")

    return AsciiJSON


def _finite(data: Any) -> Any:
    if isinstance(data, float):
        return data if math.isfinite(data) else None
    if isinstance(data, dict):
        return {k: _finite(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [_finite(v) for v in data]
    return data


def _refuse(status: int, message: str, headers: dict | None = None):
    JSONResponse = _json_response()
    body = {"ok": False, "errors": [{"line": None, "where": "", "message": message, "text": None}]}
    return JSONResponse(body, status, headers=headers)


def _busy():
    return _refuse(
        503,
        f"the server is busy (all its slots taken and {QUEUE} requests waiting); "
        f"try again in {RETRY_AFTER} s",
        {"Retry-After": str(RETRY_AFTER)},
    )


def _surrogate(data: Any, depth: int = 0) -> str | None:
    """Where ``data`` holds a lone surrogate (not Unicode text), or None."""
    if isinstance(data, str):
        for i, ch in enumerate(data):
            if "\ud800" <= ch <= "\udfff":
                line = data.count("\n", 0, i) + 1
                return f"a lone surrogate U+{ord(ch):04X} at line {line}"
        return None
    items: Any = ()
    if isinstance(data, dict):
        items = data.items()
    elif isinstance(data, list):
        items = enumerate(data)
    for k, v in items:
        found = _surrogate(k, depth) or _surrogate(v, depth + 1)
        if found:
            return found
    return None


async def _body(request) -> tuple[dict | None, Any]:
    """The request's JSON object, or (None, a 4xx response saying what is wrong)."""
    from starlette.requests import ClientDisconnect

    size = request.headers.get("content-length")
    if size is None or not size.isdigit():
        return None, _refuse(411, "a request needs a Content-Length")
    if int(size) > MAX_BODY:
        return None, _refuse(413, f"the problem is over {MAX_BODY // 1000} kB")
    try:
        raw = await request.body()
    except ClientDisconnect:  # nobody to answer: one line in the log, no traceback
        print(
            f"lamech: serve: a client hung up in the middle of its request "
            f"({request.method} {request.url.path}); nothing done",
            file=sys.stderr,
            flush=True,
        )
        return None, _refuse(400, "the request ended before its body was whole")
    if len(raw) > MAX_BODY:
        return None, _refuse(413, f"the problem is over {MAX_BODY // 1000} kB")
    try:
        data = json.loads(raw.decode("utf-8"))
    except UnicodeDecodeError:
        return None, _refuse(400, "the request is not UTF-8 text")
    except RecursionError:
        return None, _refuse(400, "the request is not JSON this server takes: nested too deeply")
    except ValueError:
        return None, _refuse(400, "the request is not JSON")
    if not isinstance(data, dict) or not isinstance(data.get("text"), str):
        return None, _refuse(400, 'the request needs "text": the problem file')
    try:
        found = _surrogate(data)
    except RecursionError:
        return None, _refuse(400, "the request is not JSON this server takes: nested too deeply")
    if found:
        return None, _refuse(400, f"the request holds {found}: not Unicode text; remove it")
    return data, None


def _initial(value: Any) -> dict[str, float | str] | str:
    """The page's partial initial state {name or name': number or text}, or what is
    wrong. A text (``"10 deg"``) is read in the child process, as ``--initial`` reads it
    (:func:`lamech.cli._workers.start_in_si`)."""
    if value is None:
        return {}
    if not isinstance(value, dict) or len(value) > 1000:
        return 'initial must be an object {"theta1": 0.01, "theta1\'": "2 deg/s"}'
    out: dict[str, float | str] = {}
    for k, v in value.items():
        if isinstance(v, str) and v.strip() and len(v) <= 200:
            out[k] = v.strip()
        elif isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            return f'initial `{k}` must be a finite number or a quantity with units ("10 deg")'
        else:
            out[k] = float(v)
    return out


def _params(value: Any) -> dict[str, float] | str:
    """A slider's parameter values {name: number} for the simulation (``mu`` or
    ``mu:<constraint>`` for a friction coefficient), or what is wrong."""
    if value is None:
        return {}
    if not isinstance(value, dict) or len(value) > 1000:
        return 'params must be an object {"mu": 0.2}'
    out = {}
    for k, v in value.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            return f"params `{k}` must be a finite number"
        out[k] = float(v)
    return out


def _grid_size(params: dict) -> int:
    size = 1
    for name, v in params.items():
        if isinstance(v, str) and v.count(":") == 2:
            n = v.rsplit(":", 1)[1].strip()
            if not n.isdigit() or len(n) > 6:
                raise ValueError(f"{name}: A:B:N needs a whole number N, got {n[:20]!r}")
            size *= int(n)
        elif isinstance(v, str):
            size *= len(v.split(","))
        elif isinstance(v, list):
            size *= len(v)
        else:
            raise ValueError(f'{name}: give "A:B:N", "a,b,c" or a list of numbers')
    return size


def _gone_when_disconnected(request) -> tuple[asyncio.Event, asyncio.Task]:
    """An event set when the client of ``request`` (its body read) goes away."""
    import asyncio

    gone = asyncio.Event()

    async def listen() -> None:
        while True:
            message = await request.receive()
            if message["type"] == "http.disconnect":
                gone.set()
                return

    return gone, asyncio.ensure_future(listen())


# ----- the web app ----------------------------------------------------------------------
def make_app(
    timeout: float = DEFAULT_TIMEOUT,
    token: str | None = None,
    port: int | None = None,
    host: str = "127.0.0.1",
    slots: int = SLOTS,
    queue: int = QUEUE,
    memory_gb: float = DEFAULT_MEMORY_GB,
):
    """The Starlette application (also what the tests drive). ``token``: the one
    requests must carry (default: random, in ``app.state.token``); ``port``/``host``:
    where it listens (the Host header must name it; ``port`` None: any port);
    ``memory_gb``: the address space of each child process."""
    import asyncio

    from starlette.applications import Starlette
    from starlette.middleware import Middleware
    from starlette.requests import Request
    from starlette.responses import HTMLResponse, PlainTextResponse
    from starlette.routing import Route

    from ..present._policy import served_policy, valid_nonce
    from ..problem import example_names, example_path, example_title
    from ._guard import LOOPBACK, Guard
    from ._headers import PageHeaders
    from ._workers import Busy, Lane, Runner, cancelled_answer

    JSONResponse = _json_response()
    token = token or secrets.token_urlsafe(32)
    runner = Runner(Lane(slots, queue), Lane(CHECK_SLOTS, CHECK_QUEUE), memory_gb)
    jobs: dict[str, dict] = {}
    controls: dict[str, tuple[asyncio.Event, list[float]]] = {}  # job: (cancel, [seen])
    tasks: set[asyncio.Task] = set()

    async def work(request: Request, kind: str, text: str, options: dict) -> Any:
        lane = runner.checks if kind == "check" else runner.work
        bound = min(timeout, CHECK_TIMEOUT) if kind == "check" else timeout
        gone, listener = _gone_when_disconnected(request)
        try:
            answer = await runner.run(lane, kind, text, options, gone, bound)
        except Busy:
            return _busy()
        finally:
            listener.cancel()
        return JSONResponse(answer, answer.pop("refused", 200))  # 400: the request's start

    async def home(request: Request) -> HTMLResponse:
        nonce = secrets.token_urlsafe(18)  # one per answer: its scripts and styles carry it
        page = PAGE.read_text(encoding="utf-8")
        for tag in ("script", "style"):
            page = page.replace(f"<{tag}>", f'<{tag} nonce="{nonce}">')
        return HTMLResponse(page, headers={"Content-Security-Policy": served_policy(nonce)})

    async def examples(request: Request) -> Any:
        return JSONResponse([{"name": n, "title": example_title(n)} for n in example_names()])

    async def example(request: Request) -> Any:
        name = request.path_params["name"]
        if name not in example_names():
            return PlainTextResponse(f"no bundled example {name[:100]!r}", 404)
        return PlainTextResponse(example_path(name).read_text(encoding="utf-8"))

    async def check(request: Request) -> Any:
        data, bad = await _body(request)
        if data is None:
            return bad
        return await work(request, "check", data["text"], {})

    async def solve(request: Request) -> Any:
        data, bad = await _body(request)
        if data is None:
            return bad
        simulate = bool(data.get("simulate"))
        t_end = data.get("t_end", 3.0)
        if simulate and (
            isinstance(t_end, bool)
            or not isinstance(t_end, (int, float))
            or not 0 < t_end <= MAX_T_END
        ):
            return _refuse(400, f"t_end must be a number in (0, {MAX_T_END:g}] seconds")
        initial = _initial(data.get("initial"))
        if isinstance(initial, str):
            return _refuse(400, initial)
        params = _params(data.get("params"))
        if isinstance(params, str):
            return _refuse(400, params)
        nonce = data.get("nonce")
        if nonce is not None and not valid_nonce(nonce):
            return _refuse(400, "nonce: 16 to 64 letters, digits, - or _ (the page's own)")
        events_only = bool(data.get("events_only"))
        if (params or events_only) and not simulate:
            return _refuse(400, '"params" and "events_only" go with "simulate": true')
        options = {
            "simulate": simulate,
            "t_end": float(t_end) if simulate else None,
            "initial": initial,
            "params": params,
            "events_only": events_only,
            "nonce": nonce,
        }
        return await work(request, "run", data["text"], options)

    async def sweep(request: Request) -> Any:
        data, bad = await _body(request)
        if data is None:
            return bad
        params, measures, t_end = data.get("params"), data.get("measures"), data.get("t_end")
        if not isinstance(params, dict) or not params:
            return _refuse(400, 'a sweep needs "params": {name: "A:B:N" or "a,b,c"}')
        if not isinstance(measures, list) or not all(isinstance(m, str) for m in measures):
            return _refuse(400, 'a sweep needs "measures": a list such as ["liftoff"]')
        if isinstance(t_end, bool) or not isinstance(t_end, (int, float)):
            return _refuse(400, f"t_end must be a number in (0, {MAX_T_END:g}] seconds")
        if not 0 < t_end <= MAX_T_END:
            return _refuse(400, f"t_end must be a number in (0, {MAX_T_END:g}] seconds")
        try:
            size = _grid_size(params)
        except ValueError as exc:
            return _refuse(400, str(exc))
        if size > MAX_CASES:
            return _refuse(
                400, f"{size} cases: the page runs at most {MAX_CASES}; use `lamech sweep`"
            )
        if runner.work.full() or runner.stopping:
            return _busy()
        key = secrets.token_hex(16)
        job: dict[str, Any] = {"done": 0, "total": size, "finished": False, "queued": True}
        finished = [k for k, j in jobs.items() if j.get("finished")]
        for old in finished[: max(0, len(finished) - 50)]:  # keep the last 50 answers
            del jobs[old]
            controls.pop(old, None)
        jobs[key] = job
        cancel, seen = asyncio.Event(), [time.monotonic()]
        controls[key] = (cancel, seen)
        options = {"params": params, "measures": measures, "t_end": float(t_end)}

        async def go() -> None:
            watchdog = asyncio.ensure_future(abandoned(cancel, seen, job))
            try:
                answer = await runner.run(
                    runner.work, "sweep", data["text"], options, cancel, 10 * timeout, job
                )
            except Busy:
                answer = {
                    "ok": False,
                    "errors": [
                        {
                            "line": None,
                            "where": "",
                            "text": None,
                            "message": "the server is busy or stopping; try again",
                        }
                    ],
                }
            finally:
                watchdog.cancel()
            if not job.get("cancelled"):  # a cancelled job keeps the answer DELETE gave it
                job.update(answer)
            job["finished"] = True

        task = asyncio.ensure_future(go())
        tasks.add(task)
        task.add_done_callback(tasks.discard)
        return JSONResponse({"ok": True, "job": key, "total": size})

    async def abandoned(cancel: asyncio.Event, seen: list[float], job: dict) -> None:
        while not job["finished"]:
            await asyncio.sleep(1.0)
            if time.monotonic() - seen[0] > SWEEP_IDLE:
                cancel.set()  # its page has gone: end its process
                return

    async def sweep_status(request: Request) -> Any:
        key = request.path_params["job"]
        job = jobs.get(key)
        if job is None:
            return _refuse(404, "no such sweep")
        if request.method == "DELETE":
            controls[key][0].set()
            cancelled = not job["finished"]
            if cancelled:  # answered now; its process is ended as soon as it is seen
                job.update(cancelled_answer())
                job["finished"] = True
            return JSONResponse({"ok": True, "cancelled": cancelled})
        controls[key][1][0] = time.monotonic()
        return JSONResponse(job)

    app = Starlette(
        routes=[
            Route("/api/sweep", sweep, methods=["POST"]),
            Route("/api/sweep/{job}", sweep_status, methods=["GET", "DELETE"]),
            Route("/", home),
            Route("/api/examples", examples),
            Route("/api/examples/{name}", example),
            Route("/api/check", check, methods=["POST"]),
            Route("/api/run", solve, methods=["POST"]),
        ],
        middleware=[
            Middleware(PageHeaders),  # outermost: a refusal carries them too
            Middleware(Guard, token=token, names=(*LOOPBACK, host), port=port),
        ],
    )
    app.state.token = token
    app.state.runner = runner
    return app


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
    if args.token is not None and not args.token.strip():
        print("lamech: --token must not be empty (leave it out for a random one)", file=sys.stderr)
        return 2
    if not (math.isfinite(args.memory) and args.memory >= 0.5):
        print(
            f"lamech: --memory {args.memory:g}: give at least 0.5 GB (default "
            f"{DEFAULT_MEMORY_GB:g}); a solve takes about 0.6 GB of address space",
            file=sys.stderr,
        )
        return 2
    refused = host_refusal(args.host)
    if refused is not None:
        print(f"lamech: {refused}", file=sys.stderr)
        return 2
    token = args.token or secrets.token_urlsafe(32)
    app = make_app(args.timeout, token=token, port=args.port, host=args.host, memory_gb=args.memory)
    runner = app.state.runner

    class Server(uvicorn.Server):
        def handle_exit(self, sig, frame) -> None:  # SIGINT, SIGTERM: end every child now
            runner.stop()
            super().handle_exit(sig, frame)

    from ._guard import bracketed

    config = uvicorn.Config(
        app, host=args.host, port=args.port, log_level="warning", timeout_graceful_shutdown=2
    )
    print(
        f"lamech: serving on http://{bracketed(args.host)}:{args.port}/?token={token} "
        "(Ctrl-C stops)",
        file=sys.stderr,
        flush=True,
    )
    Server(config).run()
    return 0
