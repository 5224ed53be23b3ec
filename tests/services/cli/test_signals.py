"""A process waiting to be stopped stops on SIGTERM even when the signal lands on another thread."""

import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent("""
    import signal, threading, time
    from gaitcap.services.cli._common import stop_on_signals

    stop = stop_on_signals()
    other = threading.Thread(target=time.sleep, args=(30,), daemon=True)  # like the bus library's threads
    other.start()
    def deliver():
        time.sleep(0.5)
        signal.pthread_kill(other.ident, signal.SIGTERM)  # the kernel may pick any thread for a kill()
    threading.Thread(target=deliver, daemon=True).start()
    stop.wait()
    print("stopped", flush=True)
""")


def test_sigterm_delivered_to_another_thread_stops_the_waiting_main_thread():
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=20)
    assert out.returncode == 0 and out.stdout.strip() == "stopped", out.stderr

