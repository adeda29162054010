"""Child-process entry point: ``python -m bake._child JOB`` runs one pickled job.

``JOB`` is a file holding a pickled ``(module, function, args)``; the child writes a
pickled ``("ok", result)`` or ``("error", message)`` to stdout. A plain interpreter
is started (not multiprocessing), so the caller's ``__main__`` is never re-imported and
a crash or hang in native code stays in the child, which the parent can kill.
"""

import importlib
import pickle
import sys


def main() -> None:
    with open(sys.argv[1], "rb") as f:
        module, function, args = pickle.load(f)
    try:
        result = ("ok", getattr(importlib.import_module(module), function)(*args))
    except Exception as exc:  # reported to the parent, which decides
        result = ("error", f"{type(exc).__name__}: {exc}")
    sys.stdout.buffer.write(pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL))
    sys.stdout.flush()


if __name__ == "__main__":
    main()
