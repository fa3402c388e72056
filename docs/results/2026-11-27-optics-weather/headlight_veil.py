"""Estimates the ego head lights' backscatter in fog, which joca does not render: the single-
scattered radiance (Henyey-Greenstein, g = 0.85) along camera rays through joca's head-light beam
(crates/joca-sim/src/lighting.rs: EGO_HEADLIGHT 0.4 relative irradiance at 1 m, half angle
0.45 rad with render::headlight's soft edge; lamps at x 2.3 m, z 0.7 m), in calibrated DN
(RADIANCE_SCALE_DN 226 per unit of relative irradiance on white, so pi * 226 per unit radiance).
Needs numpy. Usage: python3 headlight_veil.py"""
import numpy as np

K, g = 226.0, 0.85
cos_half = np.cos(0.45)


def hg(c):
    return (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * c) ** 1.5)


for V in [100, 300]:
    beta = np.log(20) / V
    for cam_x in [0.43, 2.14]:
        for down_deg in [0, 5, 10]:
            cam, lamp = np.array([cam_x, 0, 1.65]), np.array([2.3, 0, 0.7])
            a = np.radians(down_deg)
            d = np.array([np.cos(a), 0, -np.sin(a)])
            # Along the ray to the ground (or 60 m).
            smax = 60 if down_deg == 0 else min(60, 1.65 / np.sin(a))
            s = np.linspace(0.01, smax, 20000)
            ds = s[1] - s[0]
            v = cam[None, :] + s[:, None] * d[None, :] - lamp
            dist = np.sqrt((v * v).sum(1))
            along = v[:, 0] / dist
            cone = np.clip((along - cos_half) / (1 - cos_half) * 3, 0, 1) * (along > cos_half)
            irradiance = 0.4 * cone / np.maximum(dist**2, 1.0)
            cos_psi = (v / dist[:, None] * (-d[None, :])).sum(1)
            veil = K * np.pi * np.sum(beta * hg(cos_psi) * irradiance * np.exp(-beta * (s + dist))) * ds
            print(f"visibility {V} m, camera x {cam_x} m, ray {down_deg} deg down: {veil:.4f} DN")
