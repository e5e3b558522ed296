"""A clock the test sets by hand, for anything that takes a `clock` callable [s]."""


class FakeClock:
    def __init__(self, now: float = 100.0) -> None:
        self.now = now

    def __call__(self) -> float:
        return self.now
