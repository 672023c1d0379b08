//! The materials the built-in scenes share (paper section 4's components: Phong, mirror,
//! glass).

use crate::material::Material;

/// A diffuse Phong colour with a weak highlight.
pub fn matte(name: &str, diffuse: [f32; 3]) -> Material {
    Material::phong(name, diffuse, [0.05; 3], 10.0)
}

/// A mirror reflecting `reflectance` of the light, with a little diffuse colour.
pub fn mirror(name: &str, reflectance: f32) -> Material {
    let mut m = Material::phong(name, [0.02; 3], [0.0; 3], 0.0);
    m.optics.reflectance = [reflectance; 3];
    m
}

/// Clear glass of index `ior`: reflection and refraction weighted by Fresnel.
pub fn glass(name: &str, ior: f32) -> Material {
    let mut m = Material::phong(name, [0.0; 3], [0.0; 3], 0.0);
    m.optics.reflectance = [1.0; 3];
    m.optics.transmittance = [1.0; 3];
    m.optics.ior = ior;
    m.optics.fresnel = true;
    m
}
