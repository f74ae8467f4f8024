"""Config: settings are validated with messages that name the field (as given to --set)."""
import pytest

from vags_jax import config as C


def test_descent_clearance_accepts_none_and_metres():
    assert C.replace(C.Config(), **C.parse_overrides(["grasp.descent_clearance=null"])).grasp.descent_clearance is None
    assert C.replace(C.Config(), **{"grasp.descent_clearance": 0.05}).grasp.descent_clearance == 0.05


@pytest.mark.parametrize("bad", [0.0, -0.01, 0.2, "none", True])
def test_descent_clearance_rejects_bad_values(bad):
    with pytest.raises(ValueError, match=r"grasp\.descent_clearance must be null"):
        C.replace(C.Config(), **{"grasp.descent_clearance": bad})


def test_half_turn_rotations_are_set_on_both_sections_and_refuse_the_mirror_label():
    half = C.replace(C.Config(), **C.parse_overrides(["grasp.half_turn=true", "net.half_turn=true",
                                                      "grasp.n_rotations=8", "net.n_rotations=8"]))
    assert half.grasp.rotation_step == pytest.approx(3.141592653589793 / 8) and half.grasp.n_axes == 8
    assert C.Config().grasp.rotation_step == pytest.approx(3.141592653589793 / 8) and C.Config().grasp.n_axes == 8
    with pytest.raises(ValueError, match=r"net\.half_turn \(False\) must equal grasp\.half_turn \(True\)"):
        C.replace(C.Config(), **{"grasp.half_turn": True})
    with pytest.raises(ValueError, match=r"set dqn\.symmetric_grasp_label=false"):
        C.replace(half, **{"dqn.symmetric_grasp_label": True})
    from vags_jax.nets.vpg import make_vpg_net
    with pytest.raises(ValueError, match=r"net\.half_turn=false"):
        make_vpg_net(half.net)


def test_sleep_needs_impl_warp():
    assert C.replace(C.Config(), **{"sim.impl": "warp", "sim.sleep": True}).sim.sleep
    with pytest.raises(ValueError, match=r"sim\.sleep = True needs impl 'warp'.*sim\.sleep=false"):
        C.replace(C.Config(), **{"sim.sleep": True})  # default impl "jax"


@pytest.mark.parametrize("field,bad,msg", [
    ("sim.cone", "round", r"sim\.cone must be 'elliptic' or 'pyramidal'"),
    ("sim.ccd_iterations", 0, r"sim\.ccd_iterations must be an int >= 1"),
    ("sim.ccd_iterations", 2.5, r"sim\.ccd_iterations must be an int, got 2\.5 \(float\)"),
])
def test_collision_and_cone_settings_are_checked(field, bad, msg):
    with pytest.raises(ValueError, match=msg):
        C.replace(C.Config(), **{field: bad})


def test_render_batch_is_bounded_by_the_scatter_indices():
    """640 x 480 images: at most 6,990 per render group (int32 pixel indices in the heightmap
    scatter); the check names the field and the bound."""
    assert C.replace(C.Config(), **{"camera.render_batch": 6990}).camera.render_batch == 6990
    with pytest.raises(ValueError, match=r"camera\.render_batch = 8192 .* at most 6990"):
        C.replace(C.Config(), **{"camera.render_batch": 8192})


@pytest.mark.parametrize("bad", [-0.1, 1.0, 1.5])
def test_lift_hold_is_a_share_of_the_lift(bad):
    assert C.replace(C.Config(), **{"grasp.lift_hold": 0.0}).grasp.lift_hold == 0.0
    with pytest.raises(ValueError, match=r"grasp\.lift_hold must be in \[0, 1\)"):
        C.replace(C.Config(), **{"grasp.lift_hold": bad})


def test_vpg_and_push_sections_are_checked():
    cfg = C.tiny()
    with pytest.raises(ValueError, match=r"vpg.change_min must be in \[0, change_max = 0.3\) metres, got 0.3"):
        C.replace(cfg, **{"vpg.change_min": 0.3, "vpg.change_max": 0.3})
    with pytest.raises(ValueError, match=r"push.length must be in \(0, 0.5\] metres"):
        C.replace(cfg, **{"push.length": 0.0})
    # The stage's objects against the scene are checked when VPG trains, not for every config.
    small = C.replace(cfg, **{"vpg.max_objects": 5})
    with pytest.raises(ValueError, match=r"vpg.max_objects \(5\) exceeds scene.max_objects \(3\)"):
        C.check_vpg_fits(small)
    with pytest.raises(ValueError, match=r"vpg.n_worlds \(600\) exceeds replay.capacity \(512\)"):
        C.check_vpg_fits(C.replace(cfg, **{"vpg.n_worlds": 600}))


@pytest.mark.parametrize("field,default,other,bad,choices", [
    ("view_estimate", "mean", "vanet", "max", r"\('mean', 'vanet'\)"),
    ("viewpoint", "vanet", "grasp", "random", r"\('vanet', 'grasp'\)"),
    ("close_region", "seen", "map", "all", r"\('seen', 'map'\)"),
])
def test_vags_choice_is_checked(field, default, other, bad, choices):
    assert getattr(C.Config().vags, field) == default
    assert getattr(C.replace(C.Config(), **{f"vags.{field}": other}).vags, field) == other
    with pytest.raises(ValueError, match=rf"vags\.{field} must be one of {choices}, got '{bad}'"):
        C.replace(C.Config(), **{f"vags.{field}": bad})


def test_stage3_gdnet_and_its_pick_are_checked():
    assert (C.Config().vags.stage3_gdnet, C.Config().vags.stage3_gdnet_pick) == ("all", "rate")
    assert C.replace(C.Config(), **{"vags.stage3_gdnet": "frozen"}).vags.stage3_gdnet == "frozen"
    with pytest.raises(ValueError, match=r"vags\.stage3_gdnet must be one of \('all', 'direct', 'frozen'\), got 'none'"):
        C.replace(C.Config(), **{"vags.stage3_gdnet": "none"})
    with pytest.raises(ValueError, match=r"vags\.stage3_gdnet_pick must be one of \('rate', 'last'\), got 'best'"):
        C.replace(C.Config(), **{"vags.stage3_gdnet_pick": "best"})


def test_a_saved_config_without_a_later_field_reads_the_value_its_run_trained_with(tmp_path):
    """A run written before ``vags.stage3_gdnet`` trained stage 3 as "all", and one written
    before ``vags.stage3_gdnet_pick`` kept stage 3's GDNet ("last"; today's default is "rate"):
    their config.json resumes that way; a config that names the field keeps it."""
    import json

    from vags_jax.stages import checkpoint

    old = C.to_dict(C.tiny())
    del old["vags"]["stage3_gdnet"], old["vags"]["stage3_gdnet_pick"], old["vags"]["close_region"]
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "config.json").write_text(json.dumps(old))
    legacy = checkpoint.load_config(str(tmp_path / "old")).vags
    assert (legacy.stage3_gdnet, legacy.stage3_gdnet_pick) == ("all", "last")
    assert legacy.close_region == "seen"  # where runs before the field grasped after a move
    new = C.replace(C.tiny(), **{"vags.stage3_gdnet": "direct"})
    checkpoint.save_config(str(tmp_path / "new"), new)
    assert checkpoint.load_config(str(tmp_path / "new")).vags == new.vags
    assert C.from_dict(C.Config, old).vags.stage3_gdnet_pick == "rate"  # only saved runs read the legacy value
