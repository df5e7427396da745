"""Gates of the peer comparisons in tools/: each figure is checked against
its threshold, a failure is printed beside the figure and listed at the end,
and the script's exit status is 1 if any failed."""


class Gates:
    def __init__(self):
        self.failures = []

    def __call__(self, name, ok, detail):
        """Records a failure of `name` unless `ok`; returns the text to print
        after the figure ("" when it passed)."""
        if ok:
            return ""
        self.failures.append(f"{name}: {detail}")
        return f"  FAIL ({detail})"

    def report(self, label):
        """Prints the failures (or that every gate passed) under `label`;
        returns the exit status: 1 if any gate failed."""
        if self.failures:
            print(f"{label}: {len(self.failures)} gate(s) failed:")
            for f in self.failures:
                print(f"  {f}")
            return 1
        print(f"{label}: every gate passed")
        return 0
