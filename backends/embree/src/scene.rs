//! The two-level scene in Embree (paper section 3's objects and scene, mapped one to one):
//! one Embree scene per mesh holding its triangle geometry, and a top scene holding one
//! instance geometry per instance, attached under the instance's index so that Embree's
//! `instID` is our instance id and its `primID` our triangle index.

use std::time::Instant;

use glam::{Affine3A, Vec3};

use crate::device::Device;
use crate::ffi::{self, RTCGeometry, RTCScene};
use crate::EmbreeError;

/// Embree's build quality (`RTCBuildQuality`): its BVH builder's effort.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BuildQuality {
    /// Morton builder: fastest build, slowest traversal.
    Low,
    /// Binned SAH (Embree's default).
    #[default]
    Medium,
    /// SAH with spatial splits: slowest build, fastest traversal.
    High,
}

impl BuildQuality {
    pub const ALL: [BuildQuality; 3] = [Self::Low, Self::Medium, Self::High];

    pub fn name(self) -> &'static str {
        match self {
            Self::Low => "low",
            Self::Medium => "medium",
            Self::High => "high",
        }
    }

    fn raw(self) -> core::ffi::c_int {
        match self {
            Self::Low => ffi::BUILD_QUALITY_LOW,
            Self::Medium => ffi::BUILD_QUALITY_MEDIUM,
            Self::High => ffi::BUILD_QUALITY_HIGH,
        }
    }
}

impl core::str::FromStr for BuildQuality {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|q| q.name() == s)
            .ok_or_else(|| format!("unknown Embree build quality {s:?} (low, medium, high)"))
    }
}

/// How the scene is built.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BuildParams {
    /// Quality of each mesh's BVH (built once).
    pub mesh_quality: BuildQuality,
    /// Quality of the top level over the instances (rebuilt when instances move).
    pub top_quality: BuildQuality,
    /// `RTC_SCENE_FLAG_ROBUST`: watertight-leaning traversal, a little slower.
    pub robust: bool,
    /// Build threads (`None`: Embree's default, all cores). 1 for a single-thread comparison.
    pub threads: Option<usize>,
}

impl Default for BuildParams {
    /// High-quality meshes (they are built once), a fast top level, one build thread: the
    /// same split of effort as the paper's two-level BSP.
    fn default() -> Self {
        Self {
            mesh_quality: BuildQuality::High,
            top_quality: BuildQuality::Low,
            robust: false,
            threads: Some(1),
        }
    }
}

/// One mesh for Embree: vertex positions and triangles (indices into `positions`).
#[derive(Clone, Copy, Debug)]
pub struct MeshRef<'a> {
    pub positions: &'a [Vec3],
    pub indices: &'a [[u32; 3]],
}

/// One placed copy of a mesh.
#[derive(Clone, Copy, Debug)]
pub struct InstanceRef {
    pub mesh: usize,
    pub world_from_object: Affine3A,
}

/// A committed two-level Embree scene.
pub struct EmbreeScene {
    /// One scene per mesh (its triangle geometry is held by the scene).
    meshes: Vec<RTCScene>,
    /// One instance geometry per instance (kept to move the instance).
    instances: Vec<RTCGeometry>,
    /// The top scene over the instances.
    pub(crate) top: RTCScene,
    params: BuildParams,
    build_ms: f64,
    /// Dropped last: the scenes above are released first (see `Drop`).
    pub(crate) device: Device,
}

// SAFETY: a committed Embree scene may be queried from any number of threads at once (the
// library's documented contract); changes (`move_instance`) take `&mut self`.
unsafe impl Send for EmbreeScene {}
unsafe impl Sync for EmbreeScene {}

fn validate(meshes: &[MeshRef<'_>], instances: &[InstanceRef]) -> Result<(), EmbreeError> {
    for (m, mesh) in meshes.iter().enumerate() {
        if let Some(v) = mesh.positions.iter().position(|p| !p.is_finite()) {
            return Err(EmbreeError::InvalidMesh {
                mesh: m,
                problem: format!("vertex {v} is not finite ({})", mesh.positions[v]),
            });
        }
        let n = mesh.positions.len();
        if let Some(t) = mesh.indices.iter().position(|tri| tri.iter().any(|&i| i as usize >= n)) {
            return Err(EmbreeError::InvalidMesh {
                mesh: m,
                problem: format!(
                    "triangle {t} has index {:?} out of range ({n} vertices)",
                    mesh.indices[t]
                ),
            });
        }
    }
    for (i, inst) in instances.iter().enumerate() {
        check_instance(i, inst, meshes.len())?;
    }
    Ok(())
}

fn check_instance(i: usize, inst: &InstanceRef, meshes: usize) -> Result<(), EmbreeError> {
    if inst.mesh >= meshes {
        return Err(EmbreeError::InvalidInstance {
            instance: i,
            problem: format!("mesh {} out of range ({meshes} meshes)", inst.mesh),
        });
    }
    let m = inst.world_from_object;
    let det = m.matrix3.determinant();
    if !m.matrix3.is_finite() || !m.translation.is_finite() || det == 0.0 || !det.is_finite() {
        return Err(EmbreeError::InvalidInstance {
            instance: i,
            problem: format!("world_from_object is not finite and invertible ({m:?})"),
        });
    }
    Ok(())
}

/// `world_from_object` as Embree's `FLOAT3X4_COLUMN_MAJOR`: the three axes, then the
/// translation.
fn column_major(m: &Affine3A) -> [f32; 12] {
    let (x, y, z, t) = (m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis, m.translation);
    [x.x, x.y, x.z, y.x, y.y, y.z, z.x, z.y, z.z, t.x, t.y, t.z]
}

impl EmbreeScene {
    /// Builds the meshes' scenes and the top scene. Fails with the mesh or instance at fault
    /// for non-finite vertices, out-of-range indices, unknown meshes and singular transforms;
    /// degenerate triangles are kept (Embree never reports a hit on them).
    pub fn build(
        meshes: &[MeshRef<'_>],
        instances: &[InstanceRef],
        params: BuildParams,
    ) -> Result<Self, EmbreeError> {
        validate(meshes, instances)?;
        let device = Device::new(params.threads)?;
        let start = Instant::now();
        let api = device.api;
        let mut scene = Self {
            meshes: Vec::with_capacity(meshes.len()),
            instances: Vec::with_capacity(instances.len()),
            top: core::ptr::null_mut(),
            params,
            build_ms: 0.0,
            device,
        };
        let flags = ffi::SCENE_FLAG_FILTER_FUNCTION_IN_ARGUMENTS
            | if params.robust { ffi::SCENE_FLAG_ROBUST } else { ffi::SCENE_FLAG_NONE };
        for mesh in meshes {
            let raw = scene.new_scene(params.mesh_quality, flags)?;
            scene.meshes.push(raw);
            if !mesh.indices.is_empty() {
                scene.attach_triangles(raw, mesh, params.mesh_quality)?;
            }
            // SAFETY: a live scene with committed geometry.
            unsafe { (api.commit_scene)(raw) };
            scene.device.check("build a mesh's BVH")?;
        }
        scene.top = scene.new_scene(params.top_quality, flags)?;
        for (i, inst) in instances.iter().enumerate() {
            // SAFETY: a live device; instance is a geometry type of every Embree 4.
            let geom = unsafe { (api.new_geometry)(scene.device.raw, ffi::GEOMETRY_TYPE_INSTANCE) };
            scene.device.check("create an instance")?;
            scene.instances.push(geom);
            // SAFETY: live handles; the transform array outlives the call (Embree copies it).
            unsafe {
                (api.set_geometry_instanced_scene)(geom, scene.meshes[inst.mesh]);
                let xfm = column_major(&inst.world_from_object);
                (api.set_geometry_transform)(
                    geom,
                    0,
                    ffi::FORMAT_FLOAT3X4_COLUMN_MAJOR,
                    xfm.as_ptr().cast(),
                );
                (api.commit_geometry)(geom);
                (api.attach_geometry_by_id)(scene.top, geom, i as u32);
            }
            scene.device.check("attach an instance")?;
        }
        // SAFETY: a live scene whose geometries are committed.
        unsafe { (api.commit_scene)(scene.top) };
        scene.device.check("build the top level")?;
        scene.build_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(scene)
    }

    fn new_scene(
        &self,
        quality: BuildQuality,
        flags: core::ffi::c_int,
    ) -> Result<RTCScene, EmbreeError> {
        let api = self.device.api;
        // SAFETY: a live device.
        let raw = unsafe { (api.new_scene)(self.device.raw) };
        self.device.check("create a scene")?;
        // SAFETY: a live scene; quality and flags are header values.
        unsafe {
            (api.set_scene_build_quality)(raw, quality.raw());
            (api.set_scene_flags)(raw, flags);
        }
        self.device.check("set up a scene")?;
        Ok(raw)
    }

    fn attach_triangles(
        &self,
        raw: RTCScene,
        mesh: &MeshRef<'_>,
        quality: BuildQuality,
    ) -> Result<(), EmbreeError> {
        let api = self.device.api;
        // SAFETY: a live device.
        let geom = unsafe { (api.new_geometry)(self.device.raw, ffi::GEOMETRY_TYPE_TRIANGLE) };
        self.device.check("create a triangle geometry")?;
        // SAFETY: buffers are allocated by Embree with the requested size and stride (the
        // vertex buffer padded by Embree as its documentation requires for FLOAT3), written
        // in full before the geometry is committed.
        unsafe {
            (api.set_geometry_build_quality)(geom, quality.raw());
            let vertices = (api.set_new_geometry_buffer)(
                geom,
                ffi::BUFFER_TYPE_VERTEX,
                0,
                ffi::FORMAT_FLOAT3,
                12,
                mesh.positions.len(),
            ) as *mut [f32; 3];
            let indices = (api.set_new_geometry_buffer)(
                geom,
                ffi::BUFFER_TYPE_INDEX,
                0,
                ffi::FORMAT_UINT3,
                12,
                mesh.indices.len(),
            ) as *mut [u32; 3];
            if let Err(e) = self.device.check("allocate a mesh's buffers") {
                (api.release_geometry)(geom);
                return Err(e);
            }
            for (i, p) in mesh.positions.iter().enumerate() {
                vertices.add(i).write(p.to_array());
            }
            core::ptr::copy_nonoverlapping(mesh.indices.as_ptr(), indices, mesh.indices.len());
            (api.commit_geometry)(geom);
            (api.attach_geometry_by_id)(raw, geom, 0);
            // The scene holds the geometry now.
            (api.release_geometry)(geom);
        }
        self.device.check("attach a mesh")
    }

    /// Moves instance `i` and rebuilds the top level only (the meshes' BVHs are kept).
    pub fn move_instance(
        &mut self,
        i: usize,
        world_from_object: Affine3A,
    ) -> Result<(), EmbreeError> {
        let inst = InstanceRef { mesh: 0, world_from_object };
        check_instance(i, &inst, usize::MAX)?;
        let Some(&geom) = self.instances.get(i) else {
            return Err(EmbreeError::InvalidInstance {
                instance: i,
                problem: format!("no such instance ({} instances)", self.instances.len()),
            });
        };
        let api = self.device.api;
        let start = Instant::now();
        let xfm = column_major(&world_from_object);
        // SAFETY: live handles; Embree copies the transform.
        unsafe {
            (api.set_geometry_transform)(geom, 0, ffi::FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm.as_ptr().cast());
            (api.commit_geometry)(geom);
            (api.commit_scene)(self.top);
        }
        self.device.check("rebuild the top level")?;
        self.build_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(())
    }

    /// Milliseconds of the last build (all levels after `build`, the top level after
    /// `move_instance`).
    pub fn build_ms(&self) -> f64 {
        self.build_ms
    }

    /// Bytes the Embree device holds for this scene (buffers and BVHs, as its memory
    /// monitor counts them).
    pub fn memory_bytes(&self) -> usize {
        self.device.memory_bytes()
    }

    /// The parameters the scene was built with.
    pub fn params(&self) -> BuildParams {
        self.params
    }

    /// The device (library version and capabilities).
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// Number of instances.
    pub fn instance_count(&self) -> usize {
        self.instances.len()
    }
}

impl Drop for EmbreeScene {
    fn drop(&mut self) {
        let api = self.device.api;
        // SAFETY: every handle is live and released once, before the device.
        unsafe {
            for &g in &self.instances {
                (api.release_geometry)(g);
            }
            if !self.top.is_null() {
                (api.release_scene)(self.top);
            }
            for &s in &self.meshes {
                (api.release_scene)(s);
            }
        }
    }
}
