import os
import warnings

# gymnasium's checker warns about unbounded Box spaces: the state and goal are unbounded by nature.
warnings.filterwarnings("ignore", message=".*Box observation space (minimum|maximum) value.*")
os.environ.setdefault("RAYON_NUM_THREADS", "2")
