"""Networks for VAGS: trunks (DenseNet-121, small), GDNet / VANet, rotations, pretrained loading;
and GG-CNN (``ggcnn.py``; its processing, labels and training live in ``vags_jax.ggcnn_*``).

Typical use::

    from vags_jax.nets import make_qnet, init_qnet
    gdnet = make_qnet(cfg.net, "gdnet")
    variables = init_qnet(key, gdnet, 224, 224)            # {"params", "batch_stats"}
    q = gdnet.apply(variables, colour, height)              # (B, 16, 224, 224) float32
    q, upd = gdnet.apply(variables, colour, height, train=True, rotations=idx[:, None],
                         mutable=["batch_stats"])          # (B, 1, 224, 224): executed rotation
"""
from .densenet import DenseNet121
from .ggcnn import GGCNN, GGCNNConfig, GraspMaps, init_ggcnn
from .pretrained import (check_init, densenet121_key_map, initial_variables, load_densenet121, read_state_dict,
                         to_torchvision_state_dict)
from .qnet import (
    GDNet,
    QHead,
    TrunkGeometry,
    VANet,
    coarse_to_heightmap,
    count_params,
    init_qnet,
    init_variables,
    make_qnet,
    nbv_net,
    make_trunk,
    normalise_colour,
    normalise_height,
    pad_inputs,
    padded_size,
    rotated_inputs,
    rotation_angles,
    trunk_geometry,
    variable_shapes,
)
from .rotation import rotate, sample_bilinear, source_coords, unrotate
from .small import SmallTrunk

__all__ = [
    "DenseNet121", "SmallTrunk", "GGCNN", "GGCNNConfig", "GraspMaps", "init_ggcnn", "GDNet", "VANet", "QHead", "TrunkGeometry",
    "make_qnet", "nbv_net", "init_qnet", "init_variables", "variable_shapes", "make_trunk", "trunk_geometry", "padded_size", "rotation_angles",
    "normalise_colour", "normalise_height", "pad_inputs", "rotated_inputs", "coarse_to_heightmap",
    "count_params", "rotate", "unrotate", "sample_bilinear", "source_coords",
    "densenet121_key_map", "load_densenet121", "read_state_dict", "to_torchvision_state_dict", "initial_variables",
    "check_init",
]
