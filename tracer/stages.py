"""The stages of a long command: what it is doing now, and how long each part took.

A big mesh spends seconds before its first pixel (reading the file, building the tree,
choosing the automatic parameters), and a lit render seconds after its last traced pixel
(the light). A :class:`StageClock` times each stage and, when one runs longer than
:data:`SAY_AFTER` seconds, says so on stderr (``big: building the tree [####   ] 40%``), so
that no stage of a long command is silent. Library code marks its stages with
:func:`stage` and asks for a progress callback with :func:`stage_progress`; both do nothing
unless a clock is active in the calling context (``with clock:``), so that the library stays
quiet for its own callers.

``tracer render --stage-times FILE`` writes the clock's :meth:`StageClock.as_dict`.
"""

import contextlib
import contextvars
import sys
import threading
import time

from tracer.rendering.frame import ProgressBar

__all__ = ["SAY_AFTER", "StageClock", "stage", "stage_progress"]

#: a stage says what it is doing once it has run this long (seconds)
SAY_AFTER = 3.0

_ACTIVE = contextvars.ContextVar("tracer_stage_clock", default=None)


class StageClock:
    """Times the stages of one command (see the module docstring).

    Parameters
    ----------
    label : str
        Prefix of the lines written (the mesh's name).
    stream : file, optional
        Where to write (default stderr).
    quiet : bool
        Time the stages, write nothing.
    say_after : float
        Seconds after which a running stage is announced.
    """

    def __init__(self, label, stream=None, quiet=False, say_after=SAY_AFTER):
        self.label = label
        self.stream = stream or sys.stderr
        self.quiet = quiet
        self.say_after = say_after
        self.times = []          # (name, seconds), in the order the stages ended
        self._t0 = time.perf_counter()
        self._tokens = []
        self._lock = threading.Lock()

    def __enter__(self):
        self._tokens.append(_ACTIVE.set(self))
        return self

    def __exit__(self, *exc):
        _ACTIVE.reset(self._tokens.pop())
        return False

    @contextlib.contextmanager
    def stage(self, name, what):
        """Time the stage ``name`` (a short key: ``"tree"``); ``what`` says what it does
        (``"building the tree"``), written if it runs longer than ``say_after``."""
        t0 = time.perf_counter()
        said = threading.Event()
        timer = None
        if not self.quiet:
            timer = threading.Timer(self.say_after, self._say, (f"{what} ...", said))
            timer.daemon = True
            timer.start()
        try:
            yield
        finally:
            if timer is not None:
                timer.cancel()
            seconds = time.perf_counter() - t0
            with self._lock:
                self.times.append((name, seconds))
            if said.is_set():
                self._say(f"{what}: done in {seconds:.1f} s", None)

    def progress(self, what):
        """A ``progress(done, total, elapsed_s)`` callable that shows a bar for ``what`` once
        it has run ``say_after`` seconds (None when quiet)."""
        if self.quiet:
            return None
        return ProgressBar(f"{self.label}: {what}", stream=self.stream,
                           min_seconds=self.say_after)

    def _say(self, text, flag):
        tty = getattr(self.stream, "isatty", lambda: False)()
        with self._lock:            # on a terminal, over a progress bar's unfinished line
            self.stream.write(("\r\033[K" if tty else "") + f"{self.label}: {text}\n")
            self.stream.flush()
        if flag is not None:
            flag.set()

    def as_dict(self):
        """``{"stages": [{"name", "seconds"}, ...], "total_seconds"}``: every stage timed so
        far, in order, and the seconds since the clock was made."""
        return {"stages": [{"name": n, "seconds": round(s, 4)} for n, s in self.times],
                "total_seconds": round(time.perf_counter() - self._t0, 4)}


def stage(name, what):
    """``with stage(name, what):`` times a stage on the active :class:`StageClock`; nothing
    without one."""
    clock = _ACTIVE.get()
    return clock.stage(name, what) if clock is not None else contextlib.nullcontext()


def stage_progress(what):
    """The active clock's :meth:`StageClock.progress` for ``what``, or None without one."""
    clock = _ACTIVE.get()
    return clock.progress(what) if clock is not None else None
