"""Live force: a source's readings estimated as they come, shown in a browser and published on Lab Streaming Layer.

- :mod:`sailforce.live.sources`: where readings come from (a replay, the simulated arm, a serial port,
  stdin, an LSL inlet), as blocks of stamped lines;
- :mod:`sailforce.live.pipeline`: the estimate, ``sail estimate``'s stream code on threads of its own, and the tare;
- :mod:`sailforce.live.recorder`: the record button's files, never clobbering one;
- :mod:`sailforce.live.state`: what the page shows, decimated for display;
- :mod:`sailforce.live.server`: the page, its WebSocket and its token-guarded commands (aiohttp);
- :mod:`sailforce.live.lsl`: Lab Streaming Layer outlets and inlets (pylsl).
"""

from .._lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "sources": ("from_header", "gathered", "replay", "serial_lines", "simulated_arm", "stamped", "stdin_lines"),
    "pipeline": ("LivePipeline", "Rows", "StampedLines"),
    "recorder": ("Recorder",),
    "state": ("LiveState",),
    "server": ("HostPolicy", "LiveServer"),
    "lsl": ("Outlet", "inlet_blocks"),
    "browser": ("browser_page", "cpu_seconds", "latencies_ms", "live_process", "system_chromium"),
})
