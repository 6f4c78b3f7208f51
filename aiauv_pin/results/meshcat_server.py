"""meshcat's server for the live view, listening on one address (127.0.0.1 unless asked otherwise).

meshcat's own ``meshcat-server`` binds its ZeroMQ socket to 127.0.0.1 but its web server (the page
and the websocket a browser connects to) to every network interface. This module runs the same
server (:class:`meshcat.servers.zmqserver.ZMQWebSocketBridge`) in a subprocess with the web server
bound to the requested address only (``python -m aiauv_pin.results.meshcat_server --host ADDRESS``), and
prints ``zmq_url=...`` and ``web_url=...`` lines as ``meshcat-server`` does.

The server ends with the process that started it, also when that process is killed with SIGKILL
(``--parent PID``: :func:`aiauv_pin._internal.parent_death.die_with_parent`, a parent-death signal on Linux, a
watchdog elsewhere); it runs in its own session, so a Ctrl-C in a notebook cell does not stop it.
"""

from __future__ import annotations

import argparse
import atexit
import os
import subprocess
import sys
from dataclasses import dataclass

#: Address the live meshcat server listens on by default: this machine only.
DEFAULT_HOST = "127.0.0.1"


@dataclass
class MeshcatServer:
    """A running server subprocess (stopped at exit, or by :meth:`stop`).

    Attributes:
        process: The subprocess.
        zmq_url: Where ``meshcat.Visualizer(zmq_url=...)`` connects.
        web_url: The viewer page.
    """

    process: subprocess.Popen
    zmq_url: str
    web_url: str

    def stop(self) -> None:
        """Stop the server (idempotent)."""
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait()


def start_server(host: str = DEFAULT_HOST, timeout: float = 60.0) -> MeshcatServer:
    """Start the server in a subprocess listening on ``host``.

    Raises:
        RuntimeError: The server did not start (its message, one line).
    """
    command = [sys.executable, "-u", "-m", "aiauv_pin.results.meshcat_server", "--host", host]
    command += ["--parent", str(os.getpid())]  # it ends when this process ends
    process = subprocess.Popen(
        command,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=dict(os.environ),
        start_new_session=True,  # not killed with the notebook cell that started it
    )
    urls: dict[str, str] = {}
    while len(urls) < 2:
        line = process.stdout.readline().decode("utf-8", errors="replace").strip()
        if not line and process.poll() is not None:
            error = process.stderr.read().decode("utf-8", errors="replace")
            last = error.strip().splitlines()[-1] if error.strip() else "no message"
            raise RuntimeError(f"the meshcat server did not start ({last})")
        key, _, value = line.partition("=")
        if key in ("zmq_url", "web_url"):
            urls[key] = value
    server = MeshcatServer(process, urls["zmq_url"], urls["web_url"])
    atexit.register(server.stop)
    return server


def main(argv: list[str] | None = None) -> None:
    """Run the server (blocks)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--host", default=DEFAULT_HOST, help="address to listen on (127.0.0.1)")
    parser.add_argument(
        "--parent", type=int, default=None, help="end when the process with this id ends"
    )
    args = parser.parse_args(argv)
    if args.parent is not None:
        from aiauv_pin._internal.parent_death import die_with_parent

        die_with_parent(args.parent)

    import tornado.web
    from meshcat.servers.zmqserver import ZMQWebSocketBridge

    listen = tornado.web.Application.listen

    def listen_on_host(self, port, address=None, **kwargs):
        return listen(self, port, address=args.host if address is None else address, **kwargs)

    tornado.web.Application.listen = listen_on_host  # this process only
    bridge = ZMQWebSocketBridge(host=args.host)
    print(f"zmq_url={bridge.zmq_url}")
    print(f"web_url={bridge.web_url}")
    try:
        bridge.run()
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    main()
