"""vags_jax: VAGS grasping (GDNet + VANet + GG-CNN) trained in batched MuJoCo MJX worlds."""
from vags_jax import lowering

__version__ = "0.1.0"

# Before any tracing: programs lower to the same text whatever the process traced before.
lowering.pin_jaxpr_caches()
