"""A meshcat scene kept in this process (each node's latest state) and its export to one offline HTML page."""

from __future__ import annotations

import base64
import contextlib
import io
import json
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import umsgpack

READY_MESSAGE = "wbik-scene-ready"  # logged once every scene command is applied
ERROR_MESSAGE = "wbik-page-error"  # the prefix of an uncaught JavaScript error's console line


@dataclass
class SceneNode:
    """Latest state of one path of the meshcat scene tree (packed msgpack commands)."""

    object: bytes | None = None
    properties: list[bytes] = field(default_factory=list)
    transform: bytes | None = None
    animation: bytes | None = None
    children: dict[str, SceneNode] = field(default_factory=dict)

    def walk(self):
        yield self
        for child in self.children.values():
            yield from child.walk()


class SceneRecorder:
    """A meshcat window that keeps the scene in memory (no server, no browser)."""

    def __init__(self) -> None:
        self.root = SceneNode()

    def node(self, path: str) -> SceneNode:
        node = self.root
        for part in _split(path):
            node = node.children.setdefault(part, SceneNode())
        return node

    def send(self, command) -> None:
        """Apply one meshcat command (an object with ``lower()``) to the recorded tree."""
        data = command.lower()
        kind, path = data["type"], data.get("path", "")
        packed = umsgpack.packb(data)
        if kind == "set_object":
            node = self.node(path)
            node.object, node.properties = packed, []
        elif kind in ("set_transform", "set_animation"):  # the node's transform or animation
            setattr(self.node(path), kind.removeprefix("set_"), packed)
        elif kind == "set_property":
            self.node(path).properties.append(packed)
        elif kind == "delete":
            parts = _split(path)
            if not parts:
                self.root = SceneNode()
            else:
                self.node("/".join(parts[:-1])).children.pop(parts[-1], None)
        else:
            raise ValueError(f"meshcat command {kind!r} cannot be recorded")

    def commands(self) -> list[bytes]:
        """The packed commands that rebuild the scene: objects, properties, transforms, animations."""
        return [command for node in self.root.walk()
                for command in (node.object, *node.properties, node.transform, node.animation)
                if command is not None]

    def html(self, title: str = "wbik") -> str:
        return scene_html(self.commands(), title)


class ServerWindow(SceneRecorder):
    """Forwards commands to a meshcat server on localhost (started here) and records them too."""

    def __init__(self) -> None:
        super().__init__()
        from meshcat.servers.zmqserver import start_zmq_server_as_subprocess
        from meshcat.visualizer import ViewerWindow

        self.server_process, zmq_url, _ = start_zmq_server_as_subprocess()
        with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints the URL; we print it ourselves
            self._window = ViewerWindow(zmq_url=zmq_url, start_server=False, server_args=[])
        self.web_url: str = self._window.web_url

    def send(self, command) -> None:
        super().send(command)
        self._window.send(command)

    def close(self) -> None:
        """Stop the server process and close the socket (idempotent)."""
        process = getattr(self, "server_process", None)
        if process is not None and process.poll() is None:
            process.terminate()
            try:
                process.wait(timeout=5)
            except Exception:
                process.kill()
                process.wait()
        socket = getattr(self._window, "zmq_socket", None)
        if socket is not None and not socket.closed:
            socket.close(linger=0)


def _split(path: str) -> list[str]:
    return [part for part in path.split("/") if part]


@cache
def viewer_javascript() -> str:
    """meshcat's bundled viewer (``main.min.js``, three.js included)."""
    from meshcat.servers.zmqserver import VIEWER_ROOT

    return (Path(VIEWER_ROOT) / "main.min.js").read_text(encoding="utf-8")


def scene_html(commands: list[bytes], title: str = "wbik") -> str:
    """A standalone HTML page that draws the scene given as packed meshcat commands."""
    encoded = json.dumps([base64.b64encode(command).decode("ascii") for command in commands])
    script = viewer_javascript().replace("</script", "<\\/script")
    safe_title = title.replace("&", "&amp;").replace("<", "&lt;")
    return f"""<!DOCTYPE html>
<html>
<head>
<meta charset="utf-8">
<title>{safe_title}</title>
<style>
  body {{ margin: 0; }}
  #meshcat-pane {{ width: 100vw; height: 100vh; overflow: hidden; }}
</style>
</head>
<body>
<div id="meshcat-pane"></div>
<script>
window.addEventListener("error", function (event) {{
  console.log("{ERROR_MESSAGE}: " + event.message);
}});
</script>
<script>
{script}
</script>
<script>
(function () {{
  var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
  var commands = {encoded};
  for (var i = 0; i < commands.length; i++) {{
    var text = atob(commands[i]);
    var bytes = new Uint8Array(text.length);
    for (var k = 0; k < text.length; k++) {{ bytes[k] = text.charCodeAt(k); }}
    viewer.handle_command_bytearray(bytes);
  }}
  window.wbikViewer = viewer;
  console.log("{READY_MESSAGE}: " + commands.length + " commands");
}})();
</script>
</body>
</html>
"""
