"""Shared formatting for the speed tables (docs/_gen/tables/bench_*.py)."""


def n(x: float) -> str:
    """A rate, rounded to what a shared machine can tell apart."""
    return f"{x:,.0f}"


def machine_line(data: dict) -> str:
    m = data.get("machine", {})
    if not m:
        return ""
    start = m.get("load_average_at_start", [None])[0]
    end = m.get("load_average_at_end", [None])[0]
    cores = m.get("affinity")
    pinned = f", pinned to core {','.join(map(str, cores))}" if cores and len(cores) == 1 else ""
    return (
        f"Machine: {m.get('cpu_model', m.get('processor', '?'))}, {m.get('cpu_count', '?')} cores "
        f"shared with other jobs{pinned}; 1-min load average {start} at the start, {end} at the "
        f"end; Python {m.get('python', '?')}. One run."
    )
