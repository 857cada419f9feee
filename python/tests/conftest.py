import os
import warnings

# gymnasium's checker warns about unbounded Box spaces: the state and goal are unbounded by nature.
warnings.filterwarnings("ignore", message=".*Box observation space (minimum|maximum) value.*")
os.environ.setdefault("RAYON_NUM_THREADS", "2")

# Task sets the package writes on first use (the benchmark's, training sets) go to a cache of this test session,
# unless the caller chose one.
if "VERTIBENCH_CACHE" not in os.environ:
    import tempfile

    os.environ["VERTIBENCH_CACHE"] = tempfile.mkdtemp(prefix="vertibench-test-cache-")
