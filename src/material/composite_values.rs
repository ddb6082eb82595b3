//! The textured parameters and composites against Mitsuba 3 (3.9.1, `scalar_rgb`): f · cos θi
//! and the pdf at fixed direction pairs (shading frame = geometric one) at two texture
//! coordinates, one in each cell of checkerboard textures, printed by Mitsuba's `BSDF.eval` and
//! `BSDF.pdf` (Mitsuba's `si.wi` is pir's `wo`); the delta BSDFs' sampled direction and weight
//! by `BSDF.sample`. Made by this script (`mi.load_dict` of the same BSDFs):
//!
//! ```python
//! import mitsuba as mi; mi.set_variant('scalar_rgb')
//! cb = lambda c0, c1: {'type': 'checkerboard', 'color0': c0, 'color1': c1}  # rgb as {'type': 'rgb', …}
//! RD = roughdielectric ggx α 0.3, int_ior 1.5, ext_ior 1, specular_reflectance cb(rgb(.9,.6,.3), rgb(.2,.5,.8)),
//!      specular_transmittance cb(rgb(.3,.7,.5), rgb(1,.4,.1))
//! RC = roughconductor beckmann α 0.2, eta cb(rgb(.2,.9,.7), rgb(.5,.25,.3)), k cb(3.9, 2.5)
//! blend_conductor_diffuse = blendbsdf(weight cb(0.3, 0.8), RC, diffuse(cb(rgb(.8,.5,.2), rgb(.1,.6,.9))))
//! blend_dielectric_plastic = blendbsdf(weight 0.4, RD, roughplastic ggx α 0.2)
//! mask_conductor = mask(opacity cb(0.3, 0.9), RC)
//! si = mi.SurfaceInteraction3f(); si.n = [0, 0, 1]; si.sh_frame = mi.Frame3f([0, 0, 1]); si.uv = uv; si.wi = wo
//! bsdf.eval(mi.BSDFContext(), si, wi), bsdf.pdf(…); bsdf.sample(mi.BSDFContext(), si, sample1, [.5, .5])
//! ```

use std::sync::Arc;

use glam::{Vec2, Vec3};

use super::composite::{Composite, Part};
use super::conductor::ComplexIor;
use super::microfacet::{Distribution, Microfacet};
use super::{Bsdf, LocalGeometry, Slot, Textured, TransportMode};
use crate::geometry::Frame;
use crate::texture::{Checkerboard, Texture};

/// (configuration, uv, wo, wi, Mitsuba's f · cos θi, Mitsuba's pdf).
type Row = (&'static str, [f64; 2], [f64; 3], [f64; 3], [f64; 3], f64);

/// (configuration, uv, wo, sample1, Mitsuba's sampled direction, weight, pdf).
type DeltaRow = (&'static str, [f64; 2], [f64; 3], f64, [f64; 3], [f64; 3], f64);

const ROWS: &[Row] = &[
    (
        "roughdielectric_textured",
        [0.25, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        [-2.800000000e-01, -1.200000000e-01, 9.524704720e-01],
        [3.338856250e-02, 2.225904353e-02, 1.112952176e-02],
        3.718359396e-02,
    ),
    (
        "roughdielectric_textured",
        [0.25, 0.25],
        [5.000000000e-01, 2.000000000e-01, 8.426149773e-01],
        [2.000000000e-01, -4.000000000e-01, 8.944271910e-01],
        [5.942324176e-03, 3.961549606e-03, 1.980774803e-03],
        6.639516447e-03,
    ),
    (
        "roughdielectric_textured",
        [0.25, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        [-2.000000000e-01, -1.000000000e-01, -9.746794345e-01],
        [3.134013414e+00, 7.312697411e+00, 5.223355293e+00],
        2.353290176e+01,
    ),
    (
        "roughdielectric_textured",
        [0.25, 0.25],
        [1.000000000e-01, -3.000000000e-01, -9.486832981e-01],
        [2.000000000e-01, 3.000000000e-01, -9.327379053e-01],
        [2.184811421e-02, 1.456541009e-02, 7.282705046e-03],
        2.435703017e-02,
    ),
    (
        "roughdielectric_textured",
        [0.25, 0.25],
        [1.000000000e-01, -3.000000000e-01, -9.486832981e-01],
        [-1.000000000e-01, 4.000000000e-01, 9.110433579e-01],
        [5.906096458e+00, 1.378089046e+01, 9.843493462e+00],
        8.789909363e+00,
    ),
    (
        "roughdielectric_textured",
        [0.75, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        [-2.800000000e-01, -1.200000000e-01, 9.524704720e-01],
        [7.419680711e-03, 1.854920201e-02, 2.967872284e-02],
        3.718359396e-02,
    ),
    (
        "roughdielectric_textured",
        [0.75, 0.25],
        [5.000000000e-01, 2.000000000e-01, 8.426149773e-01],
        [2.000000000e-01, -4.000000000e-01, 8.944271910e-01],
        [1.320516574e-03, 3.301291261e-03, 5.282066297e-03],
        6.639516447e-03,
    ),
    (
        "roughdielectric_textured",
        [0.75, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        [-2.000000000e-01, -1.000000000e-01, -9.746794345e-01],
        [1.044671059e+01, 4.178684235e+00, 1.044671059e+00],
        2.353290176e+01,
    ),
    (
        "roughdielectric_textured",
        [0.75, 0.25],
        [1.000000000e-01, -3.000000000e-01, -9.486832981e-01],
        [2.000000000e-01, 3.000000000e-01, -9.327379053e-01],
        [4.855136853e-03, 1.213784143e-02, 1.942054741e-02],
        2.435703017e-02,
    ),
    (
        "roughdielectric_textured",
        [0.75, 0.25],
        [1.000000000e-01, -3.000000000e-01, -9.486832981e-01],
        [-1.000000000e-01, 4.000000000e-01, 9.110433579e-01],
        [1.968698692e+01, 7.874794960e+00, 1.968698740e+00],
        8.789909363e+00,
    ),
    (
        "roughconductor_textured",
        [0.25, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        [-2.800000000e-01, -1.200000000e-01, 9.524704720e-01],
        [1.986056685e+00, 1.687017441e+00, 1.763392210e+00],
        2.086401939e+00,
    ),
    (
        "roughconductor_textured",
        [0.25, 0.25],
        [5.000000000e-01, 2.000000000e-01, 8.426149773e-01],
        [2.000000000e-01, -4.000000000e-01, 8.944271910e-01],
        [3.846962005e-02, 3.267569095e-02, 3.415535390e-02],
        4.041409865e-02,
    ),
    (
        "roughconductor_textured",
        [0.75, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        [-2.800000000e-01, -1.200000000e-01, 9.524704720e-01],
        [1.595337152e+00, 1.819215536e+00, 1.770939350e+00],
        2.086401939e+00,
    ),
    (
        "roughconductor_textured",
        [0.75, 0.25],
        [5.000000000e-01, 2.000000000e-01, 8.426149773e-01],
        [2.000000000e-01, -4.000000000e-01, 8.944271910e-01],
        [3.090095147e-02, 3.523767367e-02, 3.430248424e-02],
        4.041409865e-02,
    ),
    (
        "blend_conductor_diffuse",
        [0.25, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        [-2.800000000e-01, -1.200000000e-01, 9.524704720e-01],
        [5.912470222e-01, 4.586757720e-01, 4.011873305e-01],
        6.598249674e-01,
    ),
    (
        "blend_conductor_diffuse",
        [0.25, 0.25],
        [5.000000000e-01, 2.000000000e-01, 8.426149773e-01],
        [2.000000000e-01, -4.000000000e-01, 8.944271910e-01],
        [1.899051219e-01, 1.204171404e-01, 5.238386989e-02],
        2.358468324e-01,
    ),
    (
        "blend_conductor_diffuse",
        [0.75, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        [-2.800000000e-01, -1.200000000e-01, 9.524704720e-01],
        [1.125831366e+00, 1.328023434e+00, 1.321516275e+00],
        1.551435590e+00,
    ),
    (
        "blend_conductor_diffuse",
        [0.75, 0.25],
        [5.000000000e-01, 2.000000000e-01, 8.426149773e-01],
        [2.000000000e-01, -4.000000000e-01, 8.944271910e-01],
        [3.017181717e-02, 7.591327280e-02, 1.008820906e-01],
        1.137013733e-01,
    ),
    (
        "blend_dielectric_plastic",
        [0.25, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        [-2.800000000e-01, -1.200000000e-01, 9.524704720e-01],
        [1.003581583e-01, 9.368044883e-02, 8.700273931e-02],
        2.017060816e-01,
    ),
    (
        "blend_dielectric_plastic",
        [0.25, 0.25],
        [5.000000000e-01, 2.000000000e-01, 8.426149773e-01],
        [2.000000000e-01, -4.000000000e-01, 8.944271910e-01],
        [5.017579347e-02, 4.898732901e-02, 4.779886454e-02],
        1.115524694e-01,
    ),
    (
        "blend_dielectric_plastic",
        [0.25, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        [-2.000000000e-01, -1.000000000e-01, -9.746794345e-01],
        [1.880408168e+00, 4.387618542e+00, 3.134013414e+00],
        1.411974144e+01,
    ),
    (
        "blend_dielectric_plastic",
        [0.25, 0.25],
        [1.000000000e-01, -3.000000000e-01, -9.486832981e-01],
        [2.000000000e-01, 3.000000000e-01, -9.327379053e-01],
        [1.310886908e-02, 8.739246055e-03, 4.369623028e-03],
        1.461421885e-02,
    ),
    (
        "blend_dielectric_plastic",
        [0.25, 0.25],
        [1.000000000e-01, -3.000000000e-01, -9.486832981e-01],
        [-1.000000000e-01, 4.000000000e-01, 9.110433579e-01],
        [3.543658018e+00, 8.268534660e+00, 5.906096458e+00],
        5.273945808e+00,
    ),
    (
        "blend_dielectric_plastic",
        [0.75, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        [-2.800000000e-01, -1.200000000e-01, 9.524704720e-01],
        [8.477683365e-02, 9.145454317e-02, 9.813226014e-02],
        2.017060816e-01,
    ),
    (
        "blend_dielectric_plastic",
        [0.75, 0.25],
        [5.000000000e-01, 2.000000000e-01, 8.426149773e-01],
        [2.000000000e-01, -4.000000000e-01, 8.944271910e-01],
        [4.740270972e-02, 4.859117419e-02, 4.977963865e-02],
        1.115524694e-01,
    ),
    (
        "blend_dielectric_plastic",
        [0.75, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        [-2.000000000e-01, -1.000000000e-01, -9.746794345e-01],
        [6.268026829e+00, 2.507210732e+00, 6.268026829e-01],
        1.411974144e+01,
    ),
    (
        "blend_dielectric_plastic",
        [0.75, 0.25],
        [1.000000000e-01, -3.000000000e-01, -9.486832981e-01],
        [2.000000000e-01, 3.000000000e-01, -9.327379053e-01],
        [2.913082251e-03, 7.282705046e-03, 1.165232901e-02],
        1.461421885e-02,
    ),
    (
        "blend_dielectric_plastic",
        [0.75, 0.25],
        [1.000000000e-01, -3.000000000e-01, -9.486832981e-01],
        [-1.000000000e-01, 4.000000000e-01, 9.110433579e-01],
        [1.181219292e+01, 4.724877357e+00, 1.181219339e+00],
        5.273945808e+00,
    ),
    (
        "mask_conductor",
        [0.25, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        [-2.800000000e-01, -1.200000000e-01, 9.524704720e-01],
        [1.787451029e+00, 1.518315673e+00, 1.587052941e+00],
        1.877761722e+00,
    ),
    (
        "mask_conductor",
        [0.25, 0.25],
        [5.000000000e-01, 2.000000000e-01, 8.426149773e-01],
        [2.000000000e-01, -4.000000000e-01, 8.944271910e-01],
        [3.462265804e-02, 2.940812148e-02, 3.073981777e-02],
        3.637268767e-02,
    ),
    (
        "mask_conductor",
        [0.75, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        [-2.800000000e-01, -1.200000000e-01, 9.524704720e-01],
        [4.786011577e-01, 5.457646847e-01, 5.312818289e-01],
        6.259205937e-01,
    ),
    (
        "mask_conductor",
        [0.75, 0.25],
        [5.000000000e-01, 2.000000000e-01, 8.426149773e-01],
        [2.000000000e-01, -4.000000000e-01, 8.944271910e-01],
        [9.270286188e-03, 1.057130285e-02, 1.029074565e-02],
        1.212423015e-02,
    ),
];
const DELTA_ROWS: &[DeltaRow] = &[
    (
        "conductor_textured",
        [0.25, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        0.01,
        [-3.000000119e-01, -1.000000015e-01, 9.486833215e-01],
        [9.519013166e-01, 8.085659742e-01, 8.451732397e-01],
        1.000000000e+00,
    ),
    (
        "conductor_textured",
        [0.75, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        0.01,
        [-3.000000119e-01, -1.000000015e-01, 9.486833215e-01],
        [7.646298409e-01, 8.719340563e-01, 8.487953544e-01],
        1.000000000e+00,
    ),
    (
        "dielectric_textured",
        [0.25, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        0.01,
        [-3.000000119e-01, -1.000000015e-01, 9.486833215e-01],
        [8.999999762e-01, 6.000000238e-01, 3.000000119e-01],
        4.018941522e-02,
    ),
    (
        "dielectric_textured",
        [0.25, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        0.99,
        [-2.000000179e-01, -6.666667014e-02, -9.775252342e-01],
        [1.333333552e-01, 3.111111224e-01, 2.222222388e-01],
        9.598106146e-01,
    ),
    (
        "dielectric_textured",
        [0.25, 0.25],
        [1.000000000e-01, -3.000000000e-01, -9.486832981e-01],
        0.01,
        [-1.000000015e-01, 3.000000119e-01, -9.486833215e-01],
        [8.999999762e-01, 6.000000238e-01, 3.000000119e-01],
        4.117969424e-02,
    ),
    (
        "dielectric_textured",
        [0.25, 0.25],
        [1.000000000e-01, -3.000000000e-01, -9.486832981e-01],
        0.99,
        [-1.500000060e-01, 4.500000179e-01, 8.803408742e-01],
        [6.750000119e-01, 1.574999928e+00, 1.125000000e+00],
        9.588202834e-01,
    ),
    (
        "dielectric_textured",
        [0.75, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        0.01,
        [-3.000000119e-01, -1.000000015e-01, 9.486833215e-01],
        [2.000000030e-01, 5.000000000e-01, 8.000000119e-01],
        4.018941522e-02,
    ),
    (
        "dielectric_textured",
        [0.75, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        0.99,
        [-2.000000179e-01, -6.666667014e-02, -9.775252342e-01],
        [4.444444776e-01, 1.777777970e-01, 4.444444925e-02],
        9.598106146e-01,
    ),
    (
        "dielectric_textured",
        [0.75, 0.25],
        [1.000000000e-01, -3.000000000e-01, -9.486832981e-01],
        0.01,
        [-1.000000015e-01, 3.000000119e-01, -9.486833215e-01],
        [2.000000030e-01, 5.000000000e-01, 8.000000119e-01],
        4.117969424e-02,
    ),
    (
        "dielectric_textured",
        [0.75, 0.25],
        [1.000000000e-01, -3.000000000e-01, -9.486832981e-01],
        0.99,
        [-1.500000060e-01, 4.500000179e-01, 8.803408742e-01],
        [2.250000000e+00, 9.000000358e-01, 2.250000089e-01],
        9.588202834e-01,
    ),
    (
        "thindielectric_textured",
        [0.25, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        0.01,
        [-3.000000119e-01, -1.000000015e-01, 9.486833215e-01],
        [8.999999762e-01, 6.000000238e-01, 3.000000119e-01],
        7.727326453e-02,
    ),
    (
        "thindielectric_textured",
        [0.25, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        0.99,
        [-3.000000119e-01, -1.000000015e-01, -9.486833215e-01],
        [3.000000119e-01, 6.999999881e-01, 5.000000000e-01],
        9.227267504e-01,
    ),
    (
        "thindielectric_textured",
        [0.25, 0.25],
        [1.000000000e-01, -3.000000000e-01, -9.486832981e-01],
        0.01,
        [-1.000000015e-01, 3.000000119e-01, -9.486833215e-01],
        [8.999999762e-01, 6.000000238e-01, 3.000000119e-01],
        7.727326453e-02,
    ),
    (
        "thindielectric_textured",
        [0.25, 0.25],
        [1.000000000e-01, -3.000000000e-01, -9.486832981e-01],
        0.99,
        [-1.000000015e-01, 3.000000119e-01, 9.486833215e-01],
        [3.000000119e-01, 6.999999881e-01, 5.000000000e-01],
        9.227267504e-01,
    ),
    (
        "thindielectric_textured",
        [0.75, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        0.01,
        [-3.000000119e-01, -1.000000015e-01, 9.486833215e-01],
        [2.000000030e-01, 5.000000000e-01, 8.000000119e-01],
        7.727326453e-02,
    ),
    (
        "thindielectric_textured",
        [0.75, 0.25],
        [3.000000000e-01, 1.000000000e-01, 9.486832981e-01],
        0.99,
        [-3.000000119e-01, -1.000000015e-01, -9.486833215e-01],
        [1.000000000e+00, 4.000000060e-01, 1.000000015e-01],
        9.227267504e-01,
    ),
    (
        "thindielectric_textured",
        [0.75, 0.25],
        [1.000000000e-01, -3.000000000e-01, -9.486832981e-01],
        0.01,
        [-1.000000015e-01, 3.000000119e-01, -9.486833215e-01],
        [2.000000030e-01, 5.000000000e-01, 8.000000119e-01],
        7.727326453e-02,
    ),
    (
        "thindielectric_textured",
        [0.75, 0.25],
        [1.000000000e-01, -3.000000000e-01, -9.486832981e-01],
        0.99,
        [-1.000000015e-01, 3.000000119e-01, 9.486833215e-01],
        [1.000000000e+00, 4.000000060e-01, 1.000000015e-01],
        9.227267504e-01,
    ),
];

/// Mitsuba's checkerboard of two constant colours.
fn checker(c0: Vec3, c1: Vec3) -> Texture {
    Texture::Checkerboard(Arc::new(Checkerboard {
        color0: Texture::Constant(c0),
        color1: Texture::Constant(c1),
        to_uv: glam::Affine2::IDENTITY,
    }))
}

/// A BSDF and its textures, as the Mitsuba loader makes them.
fn textured(bsdf: Bsdf, slots: Vec<(Slot, Texture)>) -> Part {
    Part { bsdf, textures: (!slots.is_empty()).then(|| Arc::new(Textured::new(slots))) }
}

/// The configurations of the rows, untextured values at the textures' means (as the loader
/// leaves them; the textures set them at a point).
fn part(name: &str) -> Part {
    let rgb = Vec3::new;
    let rough_dielectric = || {
        textured(
            Bsdf::RoughDielectric {
                eta: 1.5,
                reflectance: Vec3::splat(0.5),
                transmittance: Vec3::splat(0.5),
                microfacet: Microfacet::new(Distribution::Ggx, 0.3),
            },
            vec![
                (Slot::Specular, checker(rgb(0.9, 0.6, 0.3), rgb(0.2, 0.5, 0.8))),
                (Slot::Transmittance, checker(rgb(0.3, 0.7, 0.5), rgb(1.0, 0.4, 0.1))),
            ],
        )
    };
    let ior_slots = || {
        vec![
            (Slot::Eta, checker(rgb(0.2, 0.9, 0.7), rgb(0.5, 0.25, 0.3))),
            (Slot::K, checker(Vec3::splat(3.9), Vec3::splat(2.5))),
        ]
    };
    let mean_ior = ComplexIor { eta: Vec3::splat(0.5), k: Vec3::splat(3.0) };
    let rough_conductor = || {
        textured(
            Bsdf::RoughConductor {
                specular: Vec3::ONE,
                ior: mean_ior,
                microfacet: Microfacet::new(Distribution::Beckmann, 0.2),
            },
            ior_slots(),
        )
    };
    let composite = |c: Composite, weight: f32, slots: Vec<(Slot, Texture)>| {
        let bsdf = Bsdf::Composite { weight, parts: c.intern(), uv: None };
        Part { bsdf, textures: Some(Arc::new(Textured::new(slots))) }
    };
    let dielectric_slots = || {
        vec![
            (Slot::Specular, checker(rgb(0.9, 0.6, 0.3), rgb(0.2, 0.5, 0.8))),
            (Slot::Transmittance, checker(rgb(0.3, 0.7, 0.5), rgb(1.0, 0.4, 0.1))),
        ]
    };
    let half = Vec3::splat(0.5);
    match name {
        "roughdielectric_textured" => rough_dielectric(),
        "roughconductor_textured" => rough_conductor(),
        "blend_conductor_diffuse" => composite(
            Composite::Blend([
                rough_conductor(),
                textured(
                    Bsdf::Diffuse { albedo: half },
                    vec![(Slot::Reflectance, checker(rgb(0.8, 0.5, 0.2), rgb(0.1, 0.6, 0.9)))],
                ),
            ]),
            0.55,
            vec![(Slot::Weight, checker(Vec3::splat(0.3), Vec3::splat(0.8)))],
        ),
        "blend_dielectric_plastic" => composite(
            Composite::Blend([
                rough_dielectric(),
                textured(
                    Bsdf::rough_plastic(
                        half,
                        None,
                        1.49 / 1.000277,
                        Microfacet::new(Distribution::Ggx, 0.2),
                        false,
                    ),
                    vec![],
                ),
            ]),
            0.4,
            vec![],
        ),
        "mask_conductor" => composite(
            Composite::Mask(rough_conductor()),
            0.6,
            vec![(Slot::Opacity, checker(Vec3::splat(0.3), Vec3::splat(0.9)))],
        ),
        "conductor_textured" => textured(Bsdf::Conductor { specular: Vec3::ONE, ior: mean_ior }, ior_slots()),
        "dielectric_textured" => textured(
            Bsdf::Dielectric { ior: 1.5, reflectance: half, transmittance: half },
            dielectric_slots(),
        ),
        "thindielectric_textured" => textured(
            Bsdf::ThinDielectric { ior: 1.5, reflectance: half, transmittance: half },
            dielectric_slots(),
        ),
        _ => unreachable!("{name}"),
    }
}

fn v(a: [f64; 3]) -> Vec3 {
    Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32)
}

#[test]
fn textured_and_composite_eval_and_pdf_match_mitsuba() {
    let g = LocalGeometry { ng: Vec3::Z, frame: Frame::from_normal(Vec3::Z) };
    for &(name, uv, wo, wi, f, pdf) in ROWS {
        let b = part(name).at(Some(Vec2::new(uv[0] as f32, uv[1] as f32)));
        let (wo, wi, f) = (v(wo), v(wi), v(f));
        let ours = b.eval(&g, wo, wi, TransportMode::Radiance);
        let tol = 0.002 * f.abs() + Vec3::splat(1e-6);
        assert!(
            (ours - f).abs().cmple(tol).all(),
            "{name} uv {uv:?} wo {wo} wi {wi}: pir {ours}, Mitsuba {f}"
        );
        // Beckmann's within the 0.35 % of Mitsuba's masking fit.
        let p = b.pdf(&g, wo, wi);
        assert!(
            (p as f64 - pdf).abs() <= 0.005 * pdf + 1e-6,
            "{name} uv {uv:?} wo {wo} wi {wi}: pdf {p}, Mitsuba {pdf}"
        );
    }
}

#[test]
fn textured_delta_samples_match_mitsuba() {
    let g = LocalGeometry { ng: Vec3::Z, frame: Frame::from_normal(Vec3::Z) };
    for &(name, uv, wo, u_lobe, wi, weight, pdf) in DELTA_ROWS {
        let b = part(name).at(Some(Vec2::new(uv[0] as f32, uv[1] as f32)));
        let (wo, wi, weight) = (v(wo), v(wi), v(weight));
        let s = b.sample(&g, wo, u_lobe as f32, Vec2::splat(0.5), TransportMode::Radiance).unwrap();
        assert!(s.delta && (s.wi - wi).abs().max_element() < 1e-5, "{name}: {s:?}, Mitsuba wi {wi}");
        assert!(
            (s.weight - weight).abs().max_element() <= 1e-4 * weight.max_element(),
            "{name}: {s:?}, Mitsuba {weight}"
        );
        assert!((s.pdf as f64 - pdf).abs() <= 1e-4 * pdf, "{name}: {s:?}, Mitsuba pdf {pdf}");
    }
}
