"""Directional albedo of GGX lobes by Mitsuba 3, the independent answer for tests/albedo.rs.

Run with the peers kit's Python (../shared/peers/setup installs Mitsuba 3.9.1):
    ~/.cache/caustica-peers/bin/python tests/data/tools/mitsuba_albedo.py > tests/data/mitsuba-albedo.csv

Albedo E(wo) = ∫ f(wo, wi) |cos θi| dwi, estimated with Mitsuba's own importance sampling (the mean of
its sample weights f·|cos|/pdf), in radiance transport, for a white perfect conductor (F = 1) and for
a dielectric of IOR 1.5 seen from outside (cos > 0) and from inside (cos < 0), GGX with visible-normal
sampling, alpha = roughness² as glTF maps it.
"""
import mitsuba as mi
import drjit as dr

mi.set_variant("scalar_rgb")
N = 100_000


def albedo(bsdf, cos, seed):
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(seed)
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.n = mi.Normal3f(0, 0, 1)
    si.sh_frame = mi.Frame3f(si.n)
    si.wi = mi.Vector3f((1 - cos * cos) ** 0.5, 0, cos)
    ctx = mi.BSDFContext(mi.TransportMode.Radiance)
    total = total2 = 0.0
    for _ in range(N):
        _, weight = bsdf.sample(ctx, si, sampler.next_1d(), sampler.next_2d())
        v = float(weight[0])
        total += v
        total2 += v * v
    mean = total / N
    return mean, ((total2 / N - mean * mean) / N) ** 0.5


print("lobe,roughness,cos,albedo,standard_error")
seed = 0
for roughness in [0.3, 0.5, 0.7, 1.0]:
    alpha = roughness * roughness
    conductor = mi.load_dict({"type": "roughconductor", "material": "none", "distribution": "ggx", "alpha": alpha})
    dielectric = mi.load_dict(
        {"type": "roughdielectric", "int_ior": 1.5, "ext_ior": 1.0, "distribution": "ggx", "alpha": alpha}
    )
    for lobe, bsdf, cosines in [
        ("conductor", conductor, [0.2, 0.5, 0.8, 1.0]),
        ("dielectric", dielectric, [0.2, 0.5, 0.8, 1.0, -0.5, -0.9]),
    ]:
        for cos in cosines:
            seed += 1
            mean, se = albedo(bsdf, cos, seed)
            print(f"{lobe},{roughness},{cos},{mean:.6f},{se:.6f}", flush=True)
