"""The viewer's cold start: when this version's ray-tracing kernels are not compiled yet, the
viewer runs `rtlab warmup` in a background process at start and shows its progress, so the
first ray-traced frame does not sit behind minutes of compiling with no word said."""
from __future__ import annotations

import subprocess
import sys
import threading


class BackgroundWarmup:
    def __init__(self):
        self.status = "compiling ray-tracing kernels in the background (once per version)..."
        self.failed = ""
        self.process = subprocess.Popen([sys.executable, "-m", "app.cli", "warmup"], stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, text=True)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        last = ""
        for line in self.process.stdout:
            line = line.strip()
            if "warmup " in line:  # "rtlab: warmup 3/9: shadows (40 s)"
                step = line.split("warmup ", 1)[1]
                self.status = f"compiling ray-tracing kernels in the background: {step}"
            last = line or last
        if self.process.wait() != 0:
            self.failed = f"background kernel compile failed: {last[:200]}"

    @property
    def running(self) -> bool:
        return self.process.poll() is None or self._reader.is_alive()

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
