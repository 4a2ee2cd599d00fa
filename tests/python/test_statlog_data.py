"""Loading and downloading the Statlog data: real files, a real local HTTP server."""

from __future__ import annotations

import http.server
import io
import threading
import zipfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from mound import datasets
from mound.classify import statlog
from mound.errors import InputError


def test_loads_both_files_with_documented_counts(shared_data: Path) -> None:
    trn = statlog.load("sat.trn")
    tst = statlog.load("sat.tst")
    assert trn.x.shape == (4435, 36) and tst.x.shape == (2000, 36)
    assert int((trn.cls == 2).sum()) == 479 and int((tst.cls == 2).sum()) == 224
    assert set(trn.y) == {-1.0, 1.0}


@pytest.fixture
def trn_text(shared_data: Path) -> str:
    return (shared_data / "statlog" / "sat.trn").read_text()


def write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "sat.trn"
    p.write_text(text)
    return p


def test_missing_file_names_the_path(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="sat.trn: cannot read"):
        statlog.load_file(tmp_path / "sat.trn")


def test_truncated_file_names_file_and_line(tmp_path: Path, trn_text: str) -> None:
    cut = trn_text[: len(trn_text) // 2 + 17]  # ends in the middle of a row
    p = write(tmp_path, cut)
    with pytest.raises(InputError, match=r"sat\.trn:\d+: expected 37 columns, got \d+"):
        statlog.load_file(p)


def test_whole_rows_missing_is_reported_as_truncated(tmp_path: Path, trn_text: str) -> None:
    lines = trn_text.splitlines(keepends=True)
    p = write(tmp_path, "".join(lines[:-10]))
    with pytest.raises(InputError, match="4425 rows, expected 4435"):
        statlog.load_file(p, expected_rows=4435)


def test_non_numeric_row_names_line_and_value(tmp_path: Path, trn_text: str) -> None:
    lines = trn_text.splitlines(keepends=True)
    fields = lines[41].split()
    fields[1] = "x7"
    lines[41] = " ".join(fields) + "\r\n"
    p = write(tmp_path, "".join(lines))
    with pytest.raises(InputError, match=r"sat\.trn:42: non-numeric value 'x7'"):
        statlog.load_file(p)


def test_wrong_column_count_names_line(tmp_path: Path, trn_text: str) -> None:
    lines = trn_text.splitlines(keepends=True)
    lines[9] = "1 2 3 4 2\r\n"
    p = write(tmp_path, "".join(lines))
    with pytest.raises(InputError, match=r"sat\.trn:10: expected 37 columns, got 5"):
        statlog.load_file(p)


def test_wrong_checksum_is_rejected(tmp_path: Path, trn_text: str) -> None:
    # Same shape, one value changed: only the checksum can tell.
    lines = trn_text.splitlines(keepends=True)
    first = lines[0].split(" ")
    first[0] = str(int(first[0]) + 1)
    lines[0] = " ".join(first)
    p = write(tmp_path, "".join(lines))
    with pytest.raises(InputError, match="wrong sha256"):
        statlog.load_file(p, datasets.STATLOG.files["sat.trn"])


# --- fetch against a real HTTP server on 127.0.0.1 -------------------------------------

class Server:
    def __init__(self, files: dict[str, bytes]) -> None:
        self.files = files
        self.requests = 0
        outer = self

        class Handler(http.server.BaseHTTPRequestHandler):
            def do_GET(self) -> None:
                outer.requests += 1
                body = outer.files.get(self.path)
                if body is None:
                    self.send_error(404)
                    return
                self.send_response(200)
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *args: object) -> None:
                pass

        self.httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)
        self.thread.start()

    def url(self, path: str) -> str:
        return f"http://127.0.0.1:{self.httpd.server_address[1]}{path}"

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()


def zip_of(shared_data: Path, corrupt: bool = False) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for name in ("sat.trn", "sat.tst"):
            data = (shared_data / "statlog" / name).read_bytes()
            if corrupt and name == "sat.tst":
                data = data[:1000] + bytes([data[1000] ^ 1]) + data[1001:]
            z.writestr(name, data)
        z.writestr("sat.doc", "documentation\n")
    return buf.getvalue()


@pytest.fixture
def server(shared_data: Path) -> Iterator[Server]:
    s = Server({"/good.zip": zip_of(shared_data), "/bad.zip": zip_of(shared_data, True),
                "/notzip.zip": b"<html>moved</html>"})
    yield s
    s.close()


def test_fetch_downloads_checks_and_reuses(server: Server, tmp_path: Path,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    cache = tmp_path / "cache"
    monkeypatch.setenv("MOUND_DATA", str(cache))
    where = datasets.fetch(datasets.STATLOG, url=server.url("/good.zip"))
    assert where == cache / "statlog"
    for name, digest in datasets.STATLOG.files.items():
        assert datasets.sha256_of(where / name) == digest
    assert statlog.load("sat.tst").x.shape == (2000, 36)
    datasets.fetch(datasets.STATLOG, url=server.url("/good.zip"))
    assert server.requests == 1  # present and valid: no second download
    assert sorted(p.name for p in cache.iterdir()) == ["statlog"]


@pytest.mark.parametrize(("path", "message"), [
    ("/bad.zip", "wrong sha256"),
    ("/notzip.zip", "not a zip archive"),
    ("/missing.zip", r"download failed .*; without the network, set MOUND_DATA to a folder "
                     r"holding statlog/ \(sat\.trn, sat\.tst\)"),
])
def test_fetch_rejects_bad_downloads_and_leaves_nothing(
    server: Server, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, path: str, message: str
) -> None:
    cache = tmp_path / "cache"
    monkeypatch.setenv("MOUND_DATA", str(cache))
    with pytest.raises(InputError, match=message):
        datasets.fetch(datasets.STATLOG, url=server.url(path))
    assert not (cache / "statlog").exists()
    assert list(cache.iterdir()) == []  # no temporary folder left behind either
    with pytest.raises(InputError, match="mound data fetch"):
        statlog.load("sat.trn")
