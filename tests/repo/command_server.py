"""A fork server for the documented-commands test (``test_readme.py``): ``python`` commands start
in a fork of one prepared interpreter instead of a fresh one.

Why: the test runs about a hundred ``python`` processes. Each fresh one spends about 0.7 s of
CPU before the command's own work: importing numpy, numba, scipy, matplotlib, PIL and trimesh,
and numba setting up its typing and target tables on its first kernel. This server does that
once; each command then runs in a fork of it (a few milliseconds).

What a command gets, as from a fresh ``python``: its own process, ``sys.argv``, ``sys.path[0]``
(the script's folder, the working folder for ``-m``, ``''`` for ``-c``), environment, working
folder, stdin/stdout/stderr (the caller's file descriptors, passed over the socket) and exit
status; ``__main__`` is the script or module, and exit runs the atexit handlers after the
non-daemon threads end. Our own packages (``smoothdist``, ``tracer``) are not imported here, so
each command imports them afresh: a missing import in a command still fails. What differs: the
third-party modules above are imported already (with the server's environment: a command whose
environment sets anything those read, ``NUMBA_*``, ``MPL*``, ``OMP_*``, ``PYTHON*``..., is
answered "run it yourself" and the caller starts a fresh interpreter, as it does for interpreter
options other than ``-m`` and ``-c``).

Run: ``python command_server.py SOCKET`` (serves until killed). The client is the test's
``python`` shim (``test_readme.SHIM``): it sends ``{"argv", "cwd", "env"}`` as JSON with its fds
0, 1 and 2, and reads back 4 bytes, the exit status (``-1``: run it yourself).
"""

import array
import json
import os
import signal
import socket
import struct
import sys

#: imported before the first fork (each in a try: a missing optional one is simply not there)
PRELOAD = ("numpy", "scipy.linalg", "numba", "PIL.Image", "PIL.PngImagePlugin", "trimesh",
           "matplotlib", "matplotlib.pyplot")
#: environment variables read by those modules (at import, or by the interpreter at startup):
#: a command that sets one differently from the server runs in a fresh interpreter
READ_AT_IMPORT = ("NUMBA_", "MPL", "MATPLOTLIB", "OMP_", "OPENBLAS_", "MKL_", "PYTHON", "LD_",
                  "TRIMESH")


def prepare():
    """Import :data:`PRELOAD`, and compile one tiny function so that numba sets up its tables."""
    import importlib

    for name in PRELOAD:
        try:
            importlib.import_module(name)
        except ImportError:
            pass
    import numba

    numba.njit(lambda x: x + 1)(1)


def differs(env):
    """Whether ``env`` sets a variable of :data:`READ_AT_IMPORT` unlike this process's."""
    keys = set(env) | set(os.environ)
    return any(k.startswith(READ_AT_IMPORT) and env.get(k) != os.environ.get(k) for k in keys)


def reap(signum=None, frame=None):
    """Wait for every child that has ended (so that their CPU time counts as this process's
    children's, and so on up to the test worker that waits for the server)."""
    while True:
        try:
            pid, _ = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return


def serve(path):
    signal.signal(signal.SIGCHLD, reap)
    srv = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    srv.bind(path)
    srv.listen(16)
    while True:
        conn, _ = srv.accept()
        fds = array.array("i")
        msg, anc, _, _ = conn.recvmsg(1 << 20, socket.CMSG_LEN(3 * fds.itemsize))
        for level, kind, data in anc:
            if level == socket.SOL_SOCKET and kind == socket.SCM_RIGHTS:
                fds.frombytes(data[:len(data) - len(data) % fds.itemsize])
        while msg and not msg.endswith(b"\n"):
            more = conn.recv(1 << 20)
            if not more:
                break
            msg += more
        req = json.loads(msg)
        if len(fds) != 3 or differs(req["env"]) or not runnable(req["argv"]):
            conn.sendall(struct.pack("i", -1))
            conn.close()
            for fd in fds:
                os.close(fd)
            continue
        sys.stdout.flush()
        sys.stderr.flush()
        if os.fork() == 0:
            srv.close()
            signal.signal(signal.SIGCHLD, signal.SIG_DFL)
            for i, fd in enumerate(fds):
                os.dup2(fd, i)
                os.close(fd)
            code = 1
            try:  # whatever happens, this process never returns to the server's loop
                code = run(req)
                conn.sendall(struct.pack("i", code))
            finally:
                os._exit(code)
        conn.close()
        for fd in fds:
            os.close(fd)


def runnable(argv):
    """``-m MODULE ...``, ``-c CODE ...`` or ``SCRIPT.py ...``."""
    return bool(argv) and (argv[0] in ("-m", "-c") and len(argv) > 1
                           or not argv[0].startswith("-"))


def run(req):
    """Run one command in this (forked) process; its exit status."""
    import atexit
    import runpy
    import threading
    import traceback
    import types

    os.chdir(req["cwd"])
    os.environ.clear()
    os.environ.update(req["env"])
    argv = req["argv"]
    base = sys.path[1:]  # without this file's folder
    try:
        try:
            if argv[0] == "-m":
                sys.argv = [argv[1]] + argv[2:]
                sys.path[:] = [os.getcwd()] + base
                runpy.run_module(argv[1], run_name="__main__", alter_sys=True)
            elif argv[0] == "-c":
                sys.argv = ["-c"] + argv[2:]
                sys.path[:] = [""] + base
                main = types.ModuleType("__main__")  # as the interpreter's: in sys.modules
                sys.modules["__main__"] = main
                exec(compile(argv[1], "<string>", "exec"), main.__dict__)
            else:
                sys.argv = list(argv)
                sys.path[:] = [os.path.dirname(os.path.abspath(argv[0]))] + base
                runpy.run_path(argv[0], run_name="__main__")
            code = 0
        except SystemExit as exc:
            code = exit_status(exc.code)
        except BaseException:
            traceback.print_exc()
            code = 1
        threading._shutdown()
        atexit._run_exitfuncs()
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except Exception:
                pass
    return code


def exit_status(value):
    """``sys.exit(value)``'s status, as the interpreter maps it."""
    if value is None:
        return 0
    if isinstance(value, int):
        return value & 0xFF
    print(value, file=sys.stderr)
    return 1


if __name__ == "__main__":
    prepare()
    serve(sys.argv[1])
