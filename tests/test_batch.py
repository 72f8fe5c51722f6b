"""The Dask batch (issue 17) on a real LocalCluster of 2 worker processes: the same bits as serial bakes, a
failing shot reported with its error and log while the others finish, a worker killed mid-shot (the shot runs
again elsewhere and resumes from its checkpoint), and an unreachable scheduler refused in bounded time, as is
another service at the scheduler's port (one that answers something else, one that says nothing)."""

import os
import shutil
import signal
import socket
import threading
import time

import pytest

distributed = pytest.importorskip("distributed")

from opdeform import batch  # noqa: E402
from opdeform import shot as shots  # noqa: E402
from test_shot import write_spec  # noqa: E402


@pytest.fixture(scope="module")
def client():
    with batch.connect(workers=2) as c:
        yield c
        c.cluster.close()


def serial_copy(spec, folder):
    """The same spec baked serially in another folder: its PC2 bytes."""
    os.makedirs(folder)
    copy = shutil.copy(spec, folder)
    shots.bake(shots.load(copy), threads=1)
    return open(os.path.join(folder, "out", os.path.basename(spec).replace(".toml", ".pc2")), "rb").read()


def test_batch_matches_serial_bits_and_reports_a_failure(client, tmp_path):
    specs = [write_spec(tmp_path, f"shot{k}", last=20 + 5 * k) for k in range(3)]
    bad = write_spec(tmp_path, "bad", text=open(specs[0]).read().replace("[graph]", "[graf]"))
    results = batch.gather(specs + [bad], batch.submit(client, specs + [bad]))
    assert [r.ok for r in results] == [True, True, True, False]
    assert "graf: unknown key" in results[3].error and "Traceback" in results[3].log
    for k, (spec, result) in enumerate(zip(specs, results)):
        assert result.frames == 20 + 5 * k and result.outputs["pc2"].endswith(f"shot{k}.pc2")
        assert open(result.outputs["pc2"], "rb").read() == serial_copy(spec, tmp_path / f"serial{k}")


def test_a_shot_leaving_threads_to_the_runner_logs_the_threads_it_runs(tmp_path, capsys):
    # threads = 0 in the spec and None here: the bake runs 1 thread (was "%d" % None: the log line lost)
    text = open(write_spec(tmp_path, "any")).read().replace("threads = 1", "threads = 0")
    result = batch.bake_shot(write_spec(tmp_path, "any", text=text), None)
    assert result.ok and "baking frames 1-30 with 1 threads" in result.log, result.log
    assert "Logging error" not in capsys.readouterr().err


def test_a_killed_worker_reruns_the_shot_from_its_checkpoint(client, tmp_path):
    spec = write_spec(tmp_path, "long", last=3000, every=25)
    (future,) = batch.submit(client, [spec])
    checkpoint = tmp_path / "out" / ".long.checkpoint"
    deadline = time.monotonic() + 60
    running = []
    while not (checkpoint.exists() and running) and time.monotonic() < deadline:
        # the scheduler can learn where the shot runs after its first checkpoint is written (seen under wine)
        time.sleep(0.05)
        running = [w for w, keys in client.processing().items() if future.key in keys]
    assert checkpoint.exists() and running, (checkpoint.exists(), future.status)
    (pid,) = client.run(os.getpid, workers=running).values()
    os.kill(pid, getattr(signal, "SIGKILL", signal.SIGTERM))  # the worker dies mid-shot (Windows: TerminateProcess)
    (result,) = batch.gather([spec], [future])
    assert result.ok and "resuming after frame" in result.log, result.error
    assert open(result.outputs["pc2"], "rb").read() == serial_copy(spec, tmp_path / "serial")


def test_an_unreachable_scheduler_is_a_clear_error_in_bounded_time():
    t0 = time.monotonic()
    with pytest.raises(ConnectionError, match="tcp://127.0.0.1:9: no answer within 2 s"):
        batch.connect("tcp://127.0.0.1:9", timeout=2)
    assert time.monotonic() - t0 < 15


@pytest.fixture
def other_service():
    """A TCP server on 127.0.0.1 that answers each connection with ``reply`` (None: says nothing, holds it)."""
    server = socket.create_server(("127.0.0.1", 0))
    held = []

    def serve(reply):
        while True:
            try:
                conn, _ = server.accept()
            except OSError:  # closed at the end of the test
                return
            held.append(conn)
            if reply is not None:
                conn.sendall(reply)

    def start(reply):
        threading.Thread(target=serve, args=(reply,), daemon=True).start()
        return f"tcp://127.0.0.1:{server.getsockname()[1]}"

    yield start
    server.close()
    for conn in held:
        conn.close()


@pytest.mark.parametrize("reply, problem", [(b"HTTP/1.1 400 Bad Request\r\n\r\n", "is not a Dask scheduler"),
                                            (None, "no Dask handshake came within 2 s")],
                         ids=["an HTTP reply", "silence"])
def test_another_service_at_the_port_is_a_clear_error_within_the_timeout(other_service, reply, problem):
    # before: MemoryError "Unable to allocate 3.07 EiB" (the reply's first 8 bytes read as a length); the
    # silent service held the Client past 60 s
    address = other_service(reply)
    t0 = time.monotonic()
    with pytest.raises(ConnectionError, match=f"scheduler {address}: .*{problem}"):
        batch.connect(address, timeout=2)
    assert time.monotonic() - t0 < 15


def test_a_scheduler_at_its_address_passes_the_check(client):
    with batch.connect(client.scheduler.address, timeout=5) as other:
        assert len(other.scheduler_info()["workers"]) == 2
