"""vags_jax: VAGS grasping (GDNet + VANet + GG-CNN) trained in batched MuJoCo MJX worlds."""

__version__ = "0.1.0"
