//! The two-level scene in Embree (paper section 3's objects and scene, mapped one to one):
//! one Embree scene per mesh holding its triangle geometry, and a top scene holding one
//! instance geometry per instance, attached under the instance's index so that Embree's
//! `instID` is our instance id and its `primID` our triangle index.
//!
//! `embree4-rs` is not used: its `Scene` keeps the scene handle private and its `Device`
//! the device handle crate-private, so the packet calls (`rtcIntersect16`) cannot be made on
//! a scene it built.

use std::time::Instant;

use coherent_accel::{Aabb, BuildStats, Instance, Scene, TriAccel};
use glam::Affine3A;

use crate::EmbreeError;
use crate::device::Device;
use crate::ffi::{self, RTCScene};

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

/// Which packet queries carry Embree's COHERENT query flag. With it, Embree traces a packet
/// as one frustum (`occludedCoherent`, `intersectCoherent`) and drops to single rays only
/// when 2 lanes or fewer are left; without it, each lane's own boxes are tested and the
/// packet drops to single rays below a few active lanes. A frustum is tight around camera
/// rays and shadow rays to a point, and wide around scattered rays (environment samples,
/// diffuse bounces), where it visits far more nodes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Coherence {
    /// Every packet carries the flag.
    Coherent,
    /// No packet does.
    Incoherent,
    /// Each packet by its rays, as a renderer that knows its rays would set it: the flag
    /// when every active lane's direction lies within [`crate::COHERENT_CONE_DEGREES`] of the
    /// first active lane's.
    #[default]
    PerPacket,
}

/// How the scene is built.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct EmbreeParams {
    /// Quality of each mesh's BVH (built once).
    pub mesh_quality: BuildQuality,
    /// Quality of the top level over the instances (rebuilt when instances move).
    pub top_quality: BuildQuality,
    /// `RTC_SCENE_FLAG_ROBUST`: watertight-leaning traversal, a little slower.
    pub robust: bool,
    /// Build threads (`None`: Embree's default, all cores). 1 for a single-thread comparison.
    pub threads: Option<usize>,
    /// Which packets carry Embree's COHERENT query flag (rays of a packet travel together).
    pub coherence: Coherence,
    /// Build the scenes with `RTC_SCENE_FLAG_FILTER_FUNCTION_IN_ARGUMENTS`, which only the
    /// all-hits query needs (it records hits through a filter callback). Off, first-hit and
    /// occlusion queries run on scenes without it, and the first all-hits query builds a
    /// second copy of the scene with it (kept until the instances change).
    pub all_hits: bool,
}

impl Default for EmbreeParams {
    /// High-quality meshes (they are built once), a fast top level, one build thread: the
    /// same split of effort as the paper's two-level BSP; the COHERENT flag per packet.
    fn default() -> Self {
        Self {
            mesh_quality: BuildQuality::High,
            top_quality: BuildQuality::Low,
            robust: false,
            threads: Some(1),
            coherence: Coherence::PerPacket,
            all_hits: true,
        }
    }
}

/// The Embree accelerator: a committed two-level Embree scene.
pub struct Embree {
    /// One scene per mesh (its triangle geometry is held by the scene).
    meshes: Vec<RTCScene>,
    /// Each mesh's box, in object space.
    mesh_bounds: Vec<Aabb>,
    /// The world box of every instance, grown a little (rays with `tmin < 0` are clipped to
    /// it: Embree searches `t >= 0` only).
    pub(crate) bounds: Aabb,
    /// The top scene over the instances; with [`Self::direct`], the one mesh's scene.
    pub(crate) top: RTCScene,
    /// One instance with the identity transform: the scene is that mesh's scene, with no
    /// instance level (the BSP and obvhs skip it likewise). Its hits then carry no instance
    /// id; queries report instance 0.
    pub(crate) direct: bool,
    /// Without [`EmbreeParams::all_hits`]: the input, for the copy all-hits queries build.
    source: Option<Scene>,
    /// That copy, built with filter functions in arguments on first use.
    all_hits_twin: std::sync::OnceLock<Option<Box<Embree>>>,
    pub(crate) params: EmbreeParams,
    pub(crate) stats: BuildStats,
    /// The process's device for these build threads ([`Device::shared`]); the scenes above
    /// are released before this handle (see `Drop`).
    pub(crate) device: std::sync::Arc<Device>,
}

// SAFETY: a committed Embree scene may be queried from any number of threads at once (the
// library's documented contract); changes (`set_instances`) take `&mut self`.
unsafe impl Send for Embree {}
unsafe impl Sync for Embree {}

/// `world_from_object` as Embree's `FLOAT3X4_COLUMN_MAJOR`: the three axes, then the
/// translation.
fn column_major(m: &Affine3A) -> [f32; 12] {
    let (x, y, z, t) = (
        m.matrix3.x_axis,
        m.matrix3.y_axis,
        m.matrix3.z_axis,
        m.translation,
    );
    [x.x, x.y, x.z, y.x, y.y, y.z, z.x, z.y, z.z, t.x, t.y, t.z]
}

impl Embree {
    /// Builds the meshes' scenes and the top scene. The scene is validated first (errors
    /// name the mesh or instance); degenerate triangles (those [`TriAccel`] rejects) are
    /// handed to Embree as a single point, so they are never hit, and counted.
    pub fn build_scene(scene: &Scene, params: &EmbreeParams) -> Result<Self, EmbreeError> {
        scene.validate()?;
        let device = Device::shared(params.threads)?;
        let lock = device.alloc_lock();
        let before = device.memory_bytes();
        let start = Instant::now();
        let mut e = Self {
            meshes: Vec::with_capacity(scene.meshes.len()),
            mesh_bounds: scene.meshes.iter().map(|m| m.bounds()).collect(),
            bounds: Aabb::EMPTY,
            top: core::ptr::null_mut(),
            direct: false,
            source: (!params.all_hits).then(|| scene.clone()),
            all_hits_twin: std::sync::OnceLock::new(),
            params: *params,
            stats: BuildStats::default(),
            device: std::sync::Arc::clone(&device),
        };
        let built = e.fill(scene);
        e.stats.build_seconds = start.elapsed().as_secs_f64();
        // This scene's bytes: what the device gained during the build (no other thread
        // allocates or frees on it meanwhile).
        e.stats.memory_bytes = e.device.memory_bytes().saturating_sub(before);
        // Released before `e` can be dropped: its `Drop` takes the lock too.
        drop(lock);
        built?;
        Ok(e)
    }

    /// Builds the meshes' scenes and the top scene of a new `Embree`.
    fn fill(&mut self, scene: &Scene) -> Result<(), EmbreeError> {
        for mesh in &scene.meshes {
            let raw = self.new_scene(self.params.mesh_quality)?;
            self.meshes.push(raw);
            let (kept, degenerate) = self.attach_triangles(raw, mesh)?;
            self.stats.triangles += kept;
            self.stats.degenerate += degenerate;
            // SAFETY: a live scene with committed geometry.
            unsafe { (self.device.api.commit_scene)(raw) };
            self.device.check("build a mesh's BVH")?;
        }
        self.build_top(&scene.instances)
    }

    /// The scene on which all-hits queries run: this one when built with
    /// [`EmbreeParams::all_hits`], else the copy built with it on first use (`None` only
    /// when that build failed, which it cannot once this scene was built).
    pub(crate) fn all_hits_scene(&self) -> Option<&Embree> {
        if self.params.all_hits {
            return Some(self);
        }
        self.all_hits_twin
            .get_or_init(|| {
                let params = EmbreeParams {
                    all_hits: true,
                    ..self.params
                };
                let scene = self.source.as_ref()?;
                Embree::build_scene(scene, &params).ok().map(Box::new)
            })
            .as_deref()
    }

    fn scene_flags(&self) -> core::ffi::c_int {
        let filter = if self.params.all_hits {
            ffi::SCENE_FLAG_FILTER_FUNCTION_IN_ARGUMENTS
        } else {
            ffi::SCENE_FLAG_NONE
        };
        filter
            | if self.params.robust {
                ffi::SCENE_FLAG_ROBUST
            } else {
                ffi::SCENE_FLAG_NONE
            }
    }

    fn new_scene(&self, quality: BuildQuality) -> Result<RTCScene, EmbreeError> {
        let api = self.device.api;
        // SAFETY: a live device.
        let raw = unsafe { (api.new_scene)(self.device.raw) };
        self.device.check("create a scene")?;
        // SAFETY: a live scene; quality and flags are header values.
        unsafe {
            (api.set_scene_build_quality)(raw, quality.raw());
            (api.set_scene_flags)(raw, self.scene_flags());
        }
        self.device.check("set up a scene")?;
        Ok(raw)
    }

    /// Hands the mesh to Embree as one triangle geometry (geometry id 0 of `raw`); returns
    /// the triangles kept and dropped as degenerate.
    fn attach_triangles(
        &self,
        raw: RTCScene,
        mesh: &coherent_accel::Mesh,
    ) -> Result<(usize, usize), EmbreeError> {
        let api = self.device.api;
        // SAFETY: a live device.
        let geom = unsafe { (api.new_geometry)(self.device.raw, ffi::GEOMETRY_TYPE_TRIANGLE) };
        self.device.check("create a triangle geometry")?;
        let mut degenerate = 0;
        // SAFETY: buffers are allocated by Embree with the requested size and stride (Embree
        // pads the vertex buffer for its 16-byte loads), written in full before the geometry
        // is committed.
        unsafe {
            (api.set_geometry_build_quality)(geom, self.params.mesh_quality.raw());
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
            for (i, &tri) in mesh.indices.iter().enumerate() {
                let tri = if TriAccel::new(mesh.triangle(i), i as u32).is_some() {
                    tri
                } else {
                    degenerate += 1;
                    [tri[0]; 3]
                };
                indices.add(i).write(tri);
            }
            (api.commit_geometry)(geom);
            (api.attach_geometry_by_id)(raw, geom, 0);
            // The scene holds the geometry now.
            (api.release_geometry)(geom);
        }
        self.device.check("attach a mesh")?;
        Ok((mesh.indices.len() - degenerate, degenerate))
    }

    /// (Re)builds the top scene: one instance geometry per instance, attached under the
    /// instance's index.
    fn build_top(&mut self, instances: &[Instance]) -> Result<(), EmbreeError> {
        coherent_accel::scene::validate_instances(instances, self.meshes.len())?;
        let start = Instant::now();
        let api = self.device.api;
        if !self.top.is_null() && !self.direct {
            // SAFETY: the old top scene is live and released once; it holds its instances.
            unsafe { (api.release_scene)(self.top) };
        }
        self.top = core::ptr::null_mut();
        self.direct = false;
        if let Some(s) = &mut self.source {
            s.instances = instances.to_vec();
        }
        if let [one] = instances
            && one.world_from_object == Affine3A::IDENTITY
        {
            // The mesh's scene is the whole scene: no instance level.
            self.top = self.meshes[one.mesh];
            self.direct = true;
        } else {
            self.top = self.new_scene(self.params.top_quality)?;
        }
        for (i, inst) in instances.iter().enumerate().filter(|_| !self.direct) {
            // SAFETY: a live device; instance is a geometry type of every Embree 4.
            let geom = unsafe { (api.new_geometry)(self.device.raw, ffi::GEOMETRY_TYPE_INSTANCE) };
            self.device.check("create an instance")?;
            let xfm = column_major(&inst.world_from_object);
            // SAFETY: live handles; Embree copies the transform; the top scene holds the
            // geometry after attaching it.
            unsafe {
                (api.set_geometry_instanced_scene)(geom, self.meshes[inst.mesh]);
                (api.set_geometry_transform)(
                    geom,
                    0,
                    ffi::FORMAT_FLOAT3X4_COLUMN_MAJOR,
                    xfm.as_ptr().cast(),
                );
                (api.commit_geometry)(geom);
                (api.attach_geometry_by_id)(self.top, geom, i as u32);
                (api.release_geometry)(geom);
            }
            self.device.check("attach an instance")?;
        }
        if !self.direct {
            // SAFETY: a live scene whose geometries are committed.
            unsafe { (api.commit_scene)(self.top) };
            self.device.check("build the top level")?;
        }
        let world = instances.iter().fold(Aabb::EMPTY, |b, i| {
            b.union(self.mesh_bounds[i.mesh].transformed(&i.world_from_object))
        });
        let margin = if world.is_empty() {
            glam::Vec3::ZERO
        } else {
            glam::Vec3::splat(1e-4 * world.extent().max_element() + 1e-6)
        };
        self.bounds = if world.is_empty() {
            world
        } else {
            Aabb::new(world.min - margin, world.max + margin)
        };
        self.stats.instances = instances.len();
        self.stats.top_build_seconds = start.elapsed().as_secs_f64();
        Ok(())
    }

    /// Replaces the instances and rebuilds the top level only (the meshes' BVHs are kept).
    pub fn replace_instances(&mut self, instances: &[Instance]) -> Result<(), EmbreeError> {
        coherent_accel::scene::validate_instances(instances, self.meshes.len())?;
        // The all-hits copy holds the old instances: dropped (rebuilt on the next all-hits
        // query), and before the lock, which its `Drop` takes.
        drop(std::mem::take(&mut self.all_hits_twin));
        let device = std::sync::Arc::clone(&self.device);
        let _lock = device.alloc_lock();
        let before = device.memory_bytes() as isize;
        self.build_top(instances)?;
        let grown = device.memory_bytes() as isize - before;
        self.stats.memory_bytes = (self.stats.memory_bytes as isize + grown).max(0) as usize;
        Ok(())
    }

    /// Sets the COHERENT query flag of every later packet query (on for coherent rays such as
    /// primary and shadow rays; off for incoherent ones, where Embree is faster without it),
    /// instead of choosing it per packet.
    pub fn set_coherent(&mut self, on: bool) {
        self.params.coherence = if on {
            Coherence::Coherent
        } else {
            Coherence::Incoherent
        };
    }

    /// The parameters the scene was built with.
    pub fn params(&self) -> EmbreeParams {
        self.params
    }

    /// The device (library version and capabilities).
    pub fn device(&self) -> &Device {
        &self.device
    }
}

impl Drop for Embree {
    fn drop(&mut self) {
        let api = self.device.api;
        let _lock = self.device.alloc_lock();
        // SAFETY: every handle is live and released once, before the device.
        unsafe {
            if !self.top.is_null() && !self.direct {
                (api.release_scene)(self.top);
            }
            for &s in &self.meshes {
                (api.release_scene)(s);
            }
        }
    }
}
