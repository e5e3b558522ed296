"""One desk's preview (after IPSE): asked on its own thread (a busy twin takes seconds), it says
"computing" at once; its result is shown with its 3D paths, marked STALE (paths hidden) once the
fields no longer make the request it ran, and cleared by a send or a new scene, after which a
result still on its way is dropped."""

import threading
import time
from collections.abc import Callable
from typing import Any

import viser

from web.errands import Errands
from web.markup import show
from web.panel_html import preview_html
from web.preview import PreviewResult
from web.preview_marks import PreviewMarks

RunFn = Callable[[dict[str, Any]], tuple[PreviewResult | None, str]]  # request: (result, note)


class DeskPreview:
    def __init__(
        self,
        scene: viser.SceneApi,
        line: viser.GuiHtmlHandle,
        run: RunFn,
        typed: Callable[[], dict[str, Any] | None],  # the PTWL as the fields make it now (None: they do not)
        root: str = "/preview",  # its 3D marks' scene path (a desk has two: the PTWL's, the machine's)
    ) -> None:
        self.marks = PreviewMarks(scene, root)
        self._line, self._run, self._typed = line, run, typed
        self._of: dict[str, Any] | None = None  # the request shown
        self._shown: tuple[PreviewResult | None, str] = (None, "")
        self._generation = 0  # counts previews asked and clears: a late result is dropped
        self._lock = threading.Lock()  # one at a time
        self.errands = Errands()

    def ask(self, request: dict[str, Any]) -> None:
        """(a click) Preview `request` on its own thread."""
        if not self._lock.acquire(blocking=False):
            return  # one at a time: the one computing says so
        self._generation += 1
        generation = self._generation
        self._shown = (None, "")
        self.marks.hide()
        show(self._line, preview_html(None, time.strftime("%H:%M:%S"), "computing"))

        def run() -> None:
            try:
                self.now(request, generation)
            finally:
                self._lock.release()

        if not self.errands.run("ptwl-preview", run):
            self._lock.release()  # the console closed: no preview runs

    def now(self, request: dict[str, Any], generation: int | None = None) -> None:
        """(the preview's thread, or a test) Run `request` and show how it ends, unless a send or
        a new scene came since it was asked (`generation`): then it is of the past."""
        result, note = self._run(request)
        if generation is not None and generation != self._generation:
            return
        self._of = request
        self.show(result, note)

    def show(self, result: PreviewResult | None, note: str = "") -> None:
        """A preview's paths and exit in this browser only, with `note` (where it started from);
        None: why there is none (`note`)."""
        self._shown = (result, note)
        if result is None:
            self.marks.hide()
        else:
            self.marks.show(result)
        self.refresh(computing_done=True)

    def clear(self) -> None:
        """No preview on show: a command went out, or the scene was reset."""
        self._generation += 1  # a preview still computing is of what came before
        self._of = None
        self.show(None)

    def refresh(self, computing_done: bool = False) -> None:
        """The preview's line, stale once the PTWL as typed is not the one it ran (while one is
        computing, its line says so until its result comes)."""
        if self._lock.locked() and not computing_done:
            return
        result, note = self._shown
        stale = result is not None and self._of is not None and self._typed() != self._of
        if stale:
            self.marks.hide()
        show(self._line, preview_html(result, note, "stale" if stale else ""))
