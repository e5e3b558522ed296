"""The test browser draws the 3D view at most FRAME_CAP_HZ times a second, at VIEW_DPR pixels per
CSS pixel.

Measured on a 2-core machine (Debian Chromium, no GPU, WebGL in software): each frame of the
console's view costs ~45 ms of CPU in Chromium's GPU process, and viser keeps drawing for 250 ms
after every change to the scene, so while the arm moves the page draws as fast as that process
can (~25 frames/s, ~95% of a core) whatever the telemetry rate. Capped at 10 frames/s the GPU
process takes ~49%, at 1 frame/s ~5%. The browser tests read the view's mirror in the DOM and its
pixels after waiting for them, never the frame rate, so they run capped; the frame rate itself
is measured uncapped by `python -m bench.console`.

The cap is 5 frames/s: while the arm moves, a stack and its page took 121% of a core at 10 (GPU
process 43%, renderer 31%) and 92% at 5 (22%, 23%); the browser files took 795 CPU-s in 7:14 at
10 and 735 in 6:53 at 5 (2 workers). Below that the DOM's updates, which viser applies on the same
frames, come too seldom for the checks of what the page shows when (2 frames/s broke them). A
test of an update rate opens its page at a higher cap (`CappedBrowser.new_page(frame_cap_hz=)`).

The cap wraps the page's requestAnimationFrame (viser's render loop and its message drain both
run on it). Playwright's actionability checks run in an isolated world, which this does not
touch; `wait_for_function` runs in the page's world but polls on a timer here (console_page.py's
`until`), not on frames.

Software WebGL's cost is mostly per pixel: the same page while the arm moved took 9.5 s of the
browser's CPU in 8 s at viser's default resolution, 7.6 s at half (`fixedDpr`, viser's own
development setting, read from the page's query string before its scripts run; the init script
adds it to the address in place, keeping any query the test gave). The view is the same scene,
scaled up by the compositor: screenshots keep their size and the markers their colours."""

from typing import Any

FRAME_CAP_HZ = 5
VIEW_DPR = 0.5

CAP_TEMPLATE = """{
  try {  // not on pages whose address cannot be rewritten (about:blank): the cap still runs
    const query = new URLSearchParams(location.search);
    if (window.top === window && location.protocol.startsWith('http') && !query.has('fixedDpr')) {
      query.set('fixedDpr', 'VIEW_DPR');
      history.replaceState(history.state, '', location.pathname + '?' + query + location.hash);
    }
  } catch (err) { reportError(err); }
  const minIntervalMs = MIN_INTERVAL_MS;
  const nativeRaf = window.requestAnimationFrame.bind(window);
  let waiting = new Map();
  let nextId = 1;
  let timer = null;
  let lastMs = -Infinity;
  let running = new Map();
  const flush = () => {
    timer = null;
    lastMs = performance.now();
    nativeRaf((ts) => {
      running = waiting;
      waiting = new Map();
      for (const [id, cb] of running) {
        if (!running.has(id)) continue;  // cancelled by a callback before it in this frame
        try { cb(ts); } catch (err) { reportError(err); }  // one failure skips no other callback
      }
      running = new Map();
    });
  };
  window.requestAnimationFrame = (cb) => {
    const id = nextId++;
    waiting.set(id, cb);
    if (timer === null) timer = setTimeout(flush, Math.max(0, lastMs + minIntervalMs - performance.now()));
    return id;
  };
  window.cancelAnimationFrame = (id) => { waiting.delete(id); running.delete(id); };
}"""


def cap_script(frame_cap_hz: float = FRAME_CAP_HZ) -> str:
    """The init script that caps a page at `frame_cap_hz` frames a second, at VIEW_DPR."""
    interval_ms = str(int(1000 / frame_cap_hz))
    return CAP_TEMPLATE.replace("MIN_INTERVAL_MS", interval_ms).replace("VIEW_DPR", str(VIEW_DPR))


class CappedBrowser:
    """A Playwright Browser whose new pages draw at most FRAME_CAP_HZ frames a second."""

    def __init__(self, browser: Any, timeout_ms: float) -> None:
        self._browser = browser
        self._timeout_ms = timeout_ms
        self._pages: list[Any] = []

    def new_page(self, frame_cap_hz: float = FRAME_CAP_HZ, **kwargs: Any) -> Any:
        """A capped page whose actions and waits time out after `timeout_ms` unless told."""
        page = self._browser.new_page(**kwargs)
        page.set_default_timeout(self._timeout_ms)
        page.add_init_script(cap_script(frame_cap_hz))
        self._pages.append(page)
        return page

    def close_pages(self) -> int:
        """Close every page still open; how many were. A test that fails skips its own
        `page.close()`, and its page would go on drawing (~40% of a core, renderer and GPU
        process) under every later test of the module: in the CI run of 6bc5791 a page left by
        one failure stayed open through the six tests up to the next failure."""
        left = [page for page in self._pages if not page.is_closed()]
        for page in left:
            page.close()
        self._pages.clear()
        return len(left)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._browser, name)
