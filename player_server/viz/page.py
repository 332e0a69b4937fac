"""The HTML page around the meshcat view, for the live view and for ``replay.html``.

Pure: `page_html` returns the page as text. Both pages hold meshcat's viewer, the overlay
script (``overlay.js``: robot labels that never overlap, the clock, the legend, the replay's
slider) and its style; the live page connects to the viewer process's websocket, the replay
embeds its commands and timeline.
"""

from __future__ import annotations

import json
from html import escape
from pathlib import Path
from typing import Any

OVERLAY_JS = Path(__file__).with_name("overlay.js")

STYLE = """
body { margin: 0; font-family: "DejaVu Sans", Arial, sans-serif; }
#meshcat-pane { width: 100vw; height: 100vh; overflow: hidden; }
#murdoch-overlay { position: absolute; left: 0; top: 0; width: 100vw; height: 100vh;
  pointer-events: none; overflow: hidden; }
#murdoch-leaders { position: absolute; left: 0; top: 0; width: 100%; height: 100%; }
#murdoch-leaders line { stroke: #222; stroke-width: 1.2; }
.mo-label { position: absolute; padding: 2px 6px 3px 5px; background: rgba(255,255,255,0.92);
  border: 1px solid #333; border-left-width: 5px; border-radius: 3px; font-size: 12px;
  line-height: 15px; white-space: nowrap; color: #111; }
.mo-task { font-size: 11px; color: #222; }
.mo-sw { display: inline-block; width: 10px; height: 10px; margin: 0 3px -1px 0;
  border: 1px solid rgba(0,0,0,0.35); box-sizing: border-box; }
.mo-disc { border-radius: 50%; }
.mo-bar { height: 4px; margin-bottom: 2px; }
.mo-ring { border: 3px solid #000; border-radius: 50%; background: transparent; }
.mo-marked { outline: 2px solid #000; outline-offset: 1px; border-radius: 50%;
  margin: 0 6px -1px 4px; }
#murdoch-clock { position: absolute; left: 10px; top: 8px; padding: 3px 10px;
  background: rgba(255,255,255,0.9); border-radius: 4px; font-size: 20px;
  font-variant-numeric: tabular-nums; }
#murdoch-legend { position: absolute; left: 10px; bottom: 10px; padding: 5px 9px;
  background: rgba(255,255,255,0.9); border-radius: 4px; font-size: 12px; line-height: 17px;
  max-width: 40vw; }
#murdoch-state { display: none; }
#murdoch-replay { position: absolute; left: 50%; bottom: 12px; transform: translateX(-50%);
  width: 50vw; display: flex; gap: 8px; align-items: center; padding: 4px 8px;
  background: rgba(255,255,255,0.9); border-radius: 4px; }
#murdoch-slider { flex: 1; }
#murdoch-title { position: absolute; left: 50%; top: 8px; transform: translateX(-50%);
  padding: 3px 10px; background: rgba(255,255,255,0.9); border-radius: 4px; font-size: 14px; }
"""


def page_html(*, title: str, viewer_script: str, body_script: str) -> str:
    """`viewer_script`: the ``<script>`` element that loads meshcat's viewer; `body_script`:
    JavaScript run after it and the overlay (it makes ``viewer`` and attaches the overlay)."""
    return "\n".join([
        "<!DOCTYPE html>",
        "<html>",
        "<head>",
        '<meta charset="utf-8">',
        f"<title>{escape(title)}</title>",
        f"<style>{STYLE}</style>",
        "</head>",
        "<body>",
        '<div id="meshcat-pane"></div>',
        f'<div id="murdoch-title">{escape(title)}</div>',
        viewer_script,
        f"<script>\n{OVERLAY_JS.read_text(encoding='utf-8')}\n</script>",
        f"<script>\n{body_script}\n</script>",
        "</body>",
        "</html>",
        "",
    ])


def live_page_html(title: str = "murdoch live view") -> str:
    """The live view's page: meshcat's viewer (served next to it) fed over its websocket."""
    body = "\n".join([
        'var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));',
        "MurdochOverlay.attach(viewer, {});",
        "viewer.connect();",
    ])
    return page_html(title=title, viewer_script='<script src="main.min.js"></script>',
                     body_script=body)


def replay_body_script(commands_b64: list[str], replay: dict[str, Any]) -> str:
    """The replay's script: apply the embedded commands, then attach the overlay with the
    replay's speed, duration (simulated seconds), timeline and legend."""
    return "\n".join([
        'var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));',
        "(function () {",
        f"  var commands = {json.dumps(commands_b64)};",
        "  commands.forEach(function (b64) {",
        "    var bin = atob(b64), bytes = new Uint8Array(bin.length);",
        "    for (var i = 0; i < bin.length; i++) { bytes[i] = bin.charCodeAt(i); }",
        "    viewer.handle_command_bytearray(bytes);",
        "  });",
        "})();",
        f"var murdochOverlay = MurdochOverlay.attach(viewer, {{replay: {json.dumps(replay)}}});",
    ])
