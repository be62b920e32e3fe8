"""Progress for every command that runs longer than about two seconds (one display, on ``rich``).

One object, :class:`Progress`, used as a context manager by ``verify``, ``certify``, ``stress``,
``claims``, ``bench`` and ``run``::

    with Progress("verify", total=48, quiet=args.quiet) as p:
        for name in checks:
            p.start(name, total=examples)  # the current step (and its own count, if it has one)
            ...
            p.update(done)  # sub-progress of the step (examples); optional
            p.done(name, "PASS 1.2 s")  # one kept line; the done/left count moves on

What it shows depends on where stdout goes:

* a **terminal**: a ``rich`` live display -- the title, a bar, done/total, the current step with
  its own count, and the elapsed time, redrawn ten times a second (so the clock moves during a
  long step); every :meth:`Progress.done` and :meth:`Progress.note` line is printed above it and
  stays in the scrollback;
* **not a terminal** (CI logs, pipes): plain lines, each stamped with the wall-clock time and the
  seconds since the start, ``[06:41:07 +12.3s] verify [ 5/48] paper_claims: PASS 1.2 s``. A step
  that runs longer than ``heartbeat`` seconds without a line gets a ``still running`` line (with its
  example count), so no log is silent for longer than ``heartbeat`` (default
  :data:`HEARTBEAT` = 1.5 s; environment ``TSTARG_PROGRESS_HEARTBEAT``);
* ``quiet=True`` (``--quiet``): nothing at all.

Parallel runs: the work happens in worker processes, the display lives in the parent. Feed it the
results as they arrive -- :func:`reports._parallel.map_tasks` takes ``on_result=`` for that, and
:meth:`Progress.track` wraps any iterable of arriving results. A :class:`Progress` created inside a
worker process (``multiprocessing.parent_process()`` is set) is quiet, so workers never draw over
the parent's display.

``TSTARG_PROGRESS=plain`` forces plain lines on a terminal, ``TSTARG_PROGRESS=off`` silences every
display (as ``--quiet`` does).
"""

from __future__ import annotations

import multiprocessing
import os
import sys
import threading
import time
from typing import Any, Callable, Iterable, Iterator, TextIO

__all__ = ["Progress", "HEARTBEAT", "add_quiet_argument", "is_quiet"]

HEARTBEAT = 1.5
"""Seconds of silence after which a plain (not a terminal) display prints a ``still running`` line."""


def add_quiet_argument(parser) -> None:
    """``--quiet``: no progress output (the command's results are still printed)."""
    parser.add_argument("--quiet", action="store_true", help="no progress output")


def is_quiet(args) -> bool:
    """``--quiet`` given (or absent from this command's arguments: not quiet)."""
    return bool(getattr(args, "quiet", False))


def _heartbeat_default() -> float:
    raw = os.environ.get("TSTARG_PROGRESS_HEARTBEAT")
    if raw is None:
        return HEARTBEAT
    try:
        v = float(raw)
    except ValueError:
        raise ValueError(
            f"TSTARG_PROGRESS_HEARTBEAT must be a number of seconds, got {raw!r}"
        ) from None
    if not v > 0:
        raise ValueError(f"TSTARG_PROGRESS_HEARTBEAT must be positive, got {raw!r}")
    return v


def _in_worker() -> bool:
    return multiprocessing.parent_process() is not None


class Progress:
    """A progress display for one command: see the module docstring.

    ``title``: what runs (``"verify"``); ``total``: how many steps (``None``: unknown, shown as a
    count only; :meth:`add_total` raises it later); ``quiet``: print nothing; ``stream``: where to
    write (default ``sys.stdout``, looked up when the display starts); ``mode``: ``"rich"``,
    ``"plain"`` or ``"off"`` to override the choice made from the stream and the environment;
    ``heartbeat``: seconds of silence before a plain display says a step is still running.
    """

    def __init__(
        self,
        title: str,
        total: int | None = None,
        *,
        quiet: bool = False,
        stream: TextIO | None = None,
        mode: str | None = None,
        heartbeat: float | None = None,
        unit: str = "ex",
    ):
        if total is not None and (not isinstance(total, int) or total < 0):
            raise ValueError(f"total must be a non-negative integer or None, got {total!r}")
        if mode not in (None, "rich", "plain", "off"):
            raise ValueError(f"mode must be 'rich', 'plain', 'off' or None, got {mode!r}")
        self.title = title
        self.total = total
        self.unit = unit
        self.quiet = quiet
        self._stream: Any = stream  # TextIO; sys.stdout once open() ran
        self._mode = mode
        self.heartbeat = _heartbeat_default() if heartbeat is None else float(heartbeat)
        if not self.heartbeat > 0:
            raise ValueError(f"heartbeat must be positive seconds, got {heartbeat!r}")
        self.done_count = 0
        self.step: str | None = None
        self.step_done = 0
        self.step_total: int | None = None
        self._t0 = time.monotonic()
        self._step_t0 = self._t0
        self._last_line = self._t0
        self._lock = threading.RLock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._rich: Any = None  # rich.progress.Progress while the display runs on a terminal
        self._task: Any = None
        self._phase = False
        self.mode = "off"

    # ------------------------------------------------------------------ lifecycle
    def __enter__(self) -> "Progress":
        self.open()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def open(self) -> "Progress":
        """Start the display (the context manager calls this)."""
        stream = self._stream if self._stream is not None else sys.stdout
        self._stream = stream
        env = os.environ.get("TSTARG_PROGRESS", "").strip().lower()
        if self._mode is not None:
            mode = self._mode
        elif self.quiet or env in ("off", "0", "quiet") or _in_worker():
            mode = "off"
        elif env == "plain":
            mode = "plain"
        else:
            mode = "rich" if getattr(stream, "isatty", lambda: False)() else "plain"
        self.mode = mode
        self._t0 = self._step_t0 = self._last_line = time.monotonic()
        if mode == "rich":
            self._open_rich(stream)
        elif mode == "plain":
            self._thread = threading.Thread(target=self._beat, name="tstarg-progress", daemon=True)
            self._thread.start()
        return self

    def close(self) -> None:
        """Stop the display; a terminal keeps the final state of the bar."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
            self._thread = None
        if self._rich is not None:
            with self._lock:
                self._refresh()
            self._rich.stop()
            self._rich = None
        self.mode = "off"  # later calls draw nothing

    def _open_rich(self, stream) -> None:
        # local: rich is loaded only for a terminal display (plain lines and --quiet never need it)
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, ProgressColumn, TextColumn
        from rich.progress import Progress as _RichProgress
        from rich.spinner import Spinner
        from rich.text import Text

        t0 = self._t0

        class _Live(ProgressColumn):
            """A spinner and the command's elapsed time, both moving until the display closes
            (rich's own columns stop when the count is complete, but a command may still be
            writing its report then)."""

            def __init__(self):
                super().__init__()
                self.spinner = Spinner("dots")

            def render(self, task):
                now = time.monotonic()
                s = int(now - t0)
                clock = Text(f" {s // 3600:d}:{s // 60 % 60:02d}:{s % 60:02d}", style="cyan")
                return Text.assemble(self.spinner.render(now), clock)  # type: ignore[arg-type]

        console = Console(file=stream, force_terminal=True, highlight=False, soft_wrap=True)
        self._rich = _RichProgress(
            _Live(),
            TextColumn("[bold]{task.description}"),
            BarColumn(bar_width=24),
            MofNCompleteColumn(),
            TextColumn("{task.fields[step]}"),
            console=console,
            refresh_per_second=10,
            transient=False,
            redirect_stdout=stream is sys.stdout,
            redirect_stderr=False,
        )
        self._rich.start()
        self._task = self._rich.add_task(self.title, total=self.total, step="")

    # ------------------------------------------------------------------ the API
    def add_total(self, n: int) -> None:
        """``n`` more steps than announced (a provider that turned out to hold ``n`` checks)."""
        with self._lock:
            self.total = (self.total or 0) + int(n)
            self._refresh()

    def start(self, name: str, total: int | None = None) -> None:
        """Step ``name`` begins (``total``: its own count, e.g. examples, if it has one)."""
        with self._lock:
            self.step, self.step_done, self.step_total = name, 0, total
            self._step_t0 = time.monotonic()
            self._phase = False
            if self.mode == "plain":
                self._line(f"{self._counter(self.done_count + 1)} {name} running ...")
            self._refresh()

    def phase(self, name: str) -> None:
        """A stage that is not one of the counted steps (``writing the report``): shown as the
        current step, never counted as done."""
        with self._lock:
            self.step, self.step_done, self.step_total = name, 0, None
            self._step_t0 = time.monotonic()
            self._phase = True
            if self.mode == "plain":
                self._line(f"{self.title}: {name} ...")
            self._refresh()

    def update(self, done: int, total: int | None = None) -> None:
        """The current step has done ``done`` of its own count (drawn on a terminal; counted in
        the ``still running`` lines otherwise)."""
        with self._lock:
            self.step_done = int(done)
            if total is not None:
                self.step_total = total
            self._refresh()

    def done(self, name: str | None = None, message: str = "") -> None:
        """Step ``name`` (default: the current one) finished: one kept line, ``done`` moves on."""
        with self._lock:
            name = self.step if name is None else name
            self.done_count += 1
            if self.step == name:
                self.step = None
            self._step_t0 = time.monotonic()
            text = f"{self._counter(self.done_count)} {name}" + (f": {message}" if message else "")
            if self.mode == "plain":
                self._line(text)
            elif self.mode == "rich":
                self._rich.console.print(text, markup=False, highlight=False)
            self._refresh()

    def note(self, message: str) -> None:
        """A line that is not a step (a header, a summary): kept above the bar on a terminal."""
        with self._lock:
            if self.mode == "plain":
                self._line(message)
            elif self.mode == "rich":
                self._rich.console.print(message, markup=False, highlight=False)

    def track(
        self,
        results: Iterable,
        describe: Callable[[Any], str] | None = None,
        message: Callable[[Any], str] | None = None,
    ) -> Iterator:
        """Yield ``results`` unchanged, one :meth:`done` line per item as it arrives (the parent's
        side of a parallel run). ``describe(item)`` names the step, ``message(item)`` its result."""
        for item in results:
            self.done(
                describe(item) if describe else f"item {self.done_count + 1}",
                message(item) if message else "",
            )
            yield item

    def callback(self, describe: Callable[[int, Any], str], message=None):
        """An ``on_result(index, value)`` callable for :func:`reports._parallel.map_tasks`: one
        :meth:`done` line per result as it arrives from a worker."""

        def on_result(index: int, value: Any) -> None:
            self.done(describe(index, value), message(index, value) if message else "")

        return on_result

    @property
    def elapsed(self) -> float:
        return time.monotonic() - self._t0

    # ------------------------------------------------------------------ drawing
    def _counter(self, k: int) -> str:
        if self.total is None:
            return f"{self.title} [{k}]"
        total = max(self.total, k)  # more steps than announced: the count grows with them
        w = len(str(total))
        return f"{self.title} [{k:{w}d}/{total}]"

    def _step_text(self) -> str:
        if self.step is None:
            return ""
        if self.step_total:
            return f"{self.step}  {self.step_done}/{self.step_total} {self.unit}"
        return self.step

    def _refresh(self) -> None:
        if self.mode == "rich" and self._rich is not None:
            self._rich.update(
                self._task, completed=self.done_count, total=self.total, step=self._step_text()
            )

    def _line(self, text: str) -> None:
        now = time.monotonic()
        stamp = time.strftime("%H:%M:%S")
        try:
            self._stream.write(f"[{stamp} +{now - self._t0:.1f}s] {text}\n")
            self._stream.flush()
        except ValueError:  # the stream was closed under us (interpreter shutdown)
            return
        self._last_line = now

    def _beat(self) -> None:
        while not self._stop.wait(min(0.25, self.heartbeat / 4)):
            with self._lock:
                now = time.monotonic()
                if now - self._last_line < self.heartbeat:
                    continue
                if self.step is None:
                    what = f"{self._counter(self.done_count)} working"
                elif self._phase:
                    what = f"{self.title}: {self.step}"
                else:
                    what = f"{self._counter(self.done_count + 1)} {self._step_text()}"
                self._line(f"{what} (still running, {now - self._step_t0:.1f} s)")
