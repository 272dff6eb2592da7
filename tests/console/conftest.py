"""Fixtures of the console tests: a console over a temporary folder, small simulated-bench scenes, hostile strings."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
import urllib.request
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("starlette", reason="the console's extra is not installed: pip install '.[console]'")

ROOT = Path(__file__).resolve().parents[2]

#: strings from files that must stay data in every page
HOSTILE = {
    "script": "<script>alert('x')</script>",
    "attr": '"><img src=x onerror=alert(1)>',
    "link": "javascript:alert(1)",
    "ansi": "\x1b[31mred\x1b[0m",
}


def scene_text(*, weights: str = "[5.44, 10.526, 25.966]", repeats: int = 2, count: int = 10, sample: str | None = None,
               operator: str | None = None) -> str:  # fmt: skip
    """The packaged default scene with a small session (``weights`` × ``repeats`` blocks of ``count`` readings)."""
    from contactrig.core.scene import default_scene_text

    text = default_scene_text()
    text = re.sub(r"(?m)^count = .*$", f"count = {count}", text)
    text = re.sub(r"(?m)^repeats = .*$", f"repeats = {repeats}", text)
    if sample is not None:
        text = re.sub(r"(?m)^sample = .*$", lambda m: "sample = " + _toml_string(sample), text)
    if operator is not None:
        text = re.sub(r"(?m)^operator = .*$", lambda m: "operator = " + _toml_string(operator), text)
    return text.replace("[session]\n", f"[session]\nweights_kg = {weights}\n")


def _toml_string(s: str) -> str:
    out = s.replace("\\", "\\\\").replace('"', '\\"').replace("\x1b", "\\u001b")
    return f'"{out}"'


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    d = tmp_path / "sessions"
    d.mkdir()
    (d / "small.toml").write_text(scene_text(), encoding="utf-8")
    return d


class Client:
    """The console's app through Starlette's test client, with the token and the console's own Origin."""

    def __init__(self, root: Path, port: int = 8765) -> None:
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # Starlette's note on its httpx-based client
            from starlette.testclient import TestClient

        from contactrig.console.app import build_app
        from contactrig.console.server import make_console

        self.console = make_console(root, "127.0.0.1", port)
        self.base = f"http://127.0.0.1:{port}"
        self.http = TestClient(build_app(self.console), base_url=self.base)
        self.headers = {"x-contactrig-token": self.console.token, "origin": self.base}

    def get(self, url: str, **kw: Any) -> Any:
        return self.http.get(url, headers={**self.headers, **kw.pop("headers", {})}, **kw)

    def post(self, url: str, body: dict[str, Any], **kw: Any) -> Any:
        return self.http.post(url, json=body, headers={**self.headers, **kw.pop("headers", {})}, **kw)

    def start(self, output: str, scene: str = "small.toml", speed: str = "inf", **extra: Any) -> str:
        r = self.post("/api/runs", {"scene": scene, "sim": True, "sim_speed": speed, "output": output,
                                    "client": "tester", **extra})  # fmt: skip
        assert r.status_code == 200, r.text
        return str(r.json()["id"])

    def drive(self, run: str, decide: Callable[[dict[str, Any]], dict[str, Any] | None] | None = None,
              timeout: float = 90.0) -> dict[str, Any]:  # fmt: skip
        """Answer every question (Continue by default) until the run ends; its last state."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            s = self.get(f"/api/runs/{run}").json()
            if s["phase"] == "ended":
                return dict(s)
            if s["prompt"] is not None:
                answer = decide(s) if decide is not None else None
                if answer is None:
                    answer = {"measure": True} if s["prompt"]["event"] == "resume_choice" else {"decision": "go"}
                self.post(f"/api/runs/{run}/answer", {"prompt": s["prompt"]["id"], **answer})  # names its question
            time.sleep(0.02)
        raise AssertionError(f"run {run} did not end in {timeout} s")

    def close(self) -> None:
        self.console.close()


class ConsoleProcess:
    """``contactrig console`` in a child process; its URL read from what it prints."""

    def __init__(self, folder: Path, state: Path, *extra: str) -> None:
        env = {**os.environ, "XDG_RUNTIME_DIR": str(state)}
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "contactrig", "console", str(folder), "--port", "0", "--no-browser", *extra],
            stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT,
        )  # fmt: skip
        assert self.proc.stderr is not None
        line = self.proc.stderr.readline()
        m = re.search(r"(http://127\.0\.0\.1:\d+)/\?token=([\w-]+)", line)
        assert m, line
        self.base, self.token = m.group(1), m.group(2)

    def api(self, path: str, body: dict[str, Any] | None = None, token: bool = True) -> Any:
        headers = {"Origin": self.base, "Content-Type": "application/json"}
        if token:
            headers["X-Contactrig-Token"] = self.token
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(self.base + path, data=data, headers=headers)
        with urllib.request.urlopen(req, timeout=30) as r:
            return json.loads(r.read())

    def close(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(timeout=40)
        except subprocess.TimeoutExpired:
            self.proc.kill()


@pytest.fixture
def client(folder: Path) -> Iterator[Client]:
    c = Client(folder)
    yield c
    c.close()


@pytest.fixture(scope="module")
def console(folder: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[ConsoleProcess]:
    """A console on the test module's own module-scoped ``folder``, its state in a fresh folder (browser tests)."""
    c = ConsoleProcess(folder, tmp_path_factory.mktemp("state"))
    yield c
    c.close()


@pytest.fixture(scope="module")
def browser(request: pytest.FixtureRequest) -> Iterator[Any]:
    """One headless Chromium for the test module, its window ``BROWSER_WINDOW`` of the module (default 1000,1000)."""
    from tests.console.test_console_browser import chrome

    driver = chrome(getattr(request.module, "BROWSER_WINDOW", "1000,1000"))
    yield driver
    driver.quit()
