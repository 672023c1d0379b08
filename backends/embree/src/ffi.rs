//! The part of Embree 4's C API this backend calls, written out by hand after the 4.4 headers
//! (`include/embree4/rtcore_*.h` of Embree v4.4.0), and loaded at run time (section 3's
//! traversal, served by Embree for the comparison).
//!
//! Why by hand and not through `embree4-sys`: its bindings come from the 4.2 headers, while
//! the 4.4 library (built with instance arrays) writes `instPrimID` after `instID` in every
//! hit, past the end of the 4.2 structs; `rtcInitIntersectArguments` and friends are inline
//! in the header and absent from any binding anyway. The layouts below are the 4.4 ones for
//! `RTC_MAX_INSTANCE_LEVEL_COUNT == 1` with `RTC_GEOMETRY_INSTANCE_ARRAY`, and the tests in
//! `abi.rs` check them against the library (guard words around every struct it writes).

#![allow(non_camel_case_types, non_snake_case, clippy::upper_case_acronyms)]

use core::ffi::{c_char, c_int, c_uint, c_void};

pub type RTCDevice = *mut c_void;
pub type RTCScene = *mut c_void;
pub type RTCGeometry = *mut c_void;

/// `RTC_INVALID_GEOMETRY_ID`.
pub const INVALID_ID: u32 = u32::MAX;

// enum RTCDeviceProperty
pub const DEVICE_PROPERTY_VERSION: c_int = 0;
pub const DEVICE_PROPERTY_VERSION_MAJOR: c_int = 1;
pub const DEVICE_PROPERTY_NATIVE_RAY4_SUPPORTED: c_int = 32;
pub const DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED: c_int = 33;
pub const DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED: c_int = 34;
pub const DEVICE_PROPERTY_BACKFACE_CULLING_ENABLED: c_int = 65;
pub const DEVICE_PROPERTY_FILTER_FUNCTION_SUPPORTED: c_int = 66;

// enum RTCError
pub const ERROR_NONE: c_int = 0;

// enum RTCGeometryType
pub const GEOMETRY_TYPE_TRIANGLE: c_int = 0;
pub const GEOMETRY_TYPE_INSTANCE: c_int = 121;

// enum RTCBufferType
pub const BUFFER_TYPE_INDEX: c_int = 0;
pub const BUFFER_TYPE_VERTEX: c_int = 1;

// enum RTCFormat
pub const FORMAT_UINT3: c_int = 0x5003;
pub const FORMAT_FLOAT3: c_int = 0x9003;
pub const FORMAT_FLOAT3X4_COLUMN_MAJOR: c_int = 0x9234;

// enum RTCBuildQuality
pub const BUILD_QUALITY_LOW: c_int = 0;
pub const BUILD_QUALITY_MEDIUM: c_int = 1;
pub const BUILD_QUALITY_HIGH: c_int = 2;

// enum RTCSceneFlags
pub const SCENE_FLAG_NONE: c_int = 0;
pub const SCENE_FLAG_ROBUST: c_int = 1 << 2;
pub const SCENE_FLAG_FILTER_FUNCTION_IN_ARGUMENTS: c_int = 1 << 3;

// enum RTCRayQueryFlags
pub const RAY_QUERY_FLAG_INVOKE_ARGUMENT_FILTER: c_int = 1 << 1;
pub const RAY_QUERY_FLAG_INCOHERENT: c_int = 0;
pub const RAY_QUERY_FLAG_COHERENT: c_int = 1 << 16;

/// `RTC_FEATURE_FLAG_ALL` (an enum in C, so an `int` holding all bits).
pub const FEATURE_FLAG_ALL: c_int = -1;

/// `struct RTCRay`.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCRay {
    pub org_x: f32,
    pub org_y: f32,
    pub org_z: f32,
    pub tnear: f32,
    pub dir_x: f32,
    pub dir_y: f32,
    pub dir_z: f32,
    pub time: f32,
    pub tfar: f32,
    pub mask: u32,
    pub id: u32,
    pub flags: u32,
}

/// `struct RTCHit` of 4.4: `instPrimID` follows `instID` (48 bytes with the alignment; the
/// 4.2 struct was 32).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCHit {
    pub Ng_x: f32,
    pub Ng_y: f32,
    pub Ng_z: f32,
    pub u: f32,
    pub v: f32,
    pub primID: u32,
    pub geomID: u32,
    pub instID: [u32; 1],
    pub instPrimID: [u32; 1],
}

/// `struct RTCRayHit`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCRayHit {
    pub ray: RTCRay,
    pub hit: RTCHit,
}

/// `struct RTCRayK` + `struct RTCHitK` (K = 4, 8, 16) in one: the ray arrays (12 K words)
/// followed by the hit arrays (9 K words in 4.4). The C structs are aligned to `4 K` bytes
/// (at least 16); 64 here serves every width, and as the ray part is `48 K` bytes the hit
/// part starts where C puts it.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
pub struct RTCRayHitK<const K: usize> {
    pub org_x: [f32; K],
    pub org_y: [f32; K],
    pub org_z: [f32; K],
    pub tnear: [f32; K],
    pub dir_x: [f32; K],
    pub dir_y: [f32; K],
    pub dir_z: [f32; K],
    pub time: [f32; K],
    pub tfar: [f32; K],
    pub mask: [u32; K],
    pub id: [u32; K],
    pub flags: [u32; K],
    // hit
    pub Ng_x: [f32; K],
    pub Ng_y: [f32; K],
    pub Ng_z: [f32; K],
    pub u: [f32; K],
    pub v: [f32; K],
    pub primID: [u32; K],
    pub geomID: [u32; K],
    pub instID: [[u32; K]; 1],
    pub instPrimID: [[u32; K]; 1],
}

impl<const K: usize> Default for RTCRayHitK<K> {
    fn default() -> Self {
        Self {
            org_x: [0.0; K],
            org_y: [0.0; K],
            org_z: [0.0; K],
            tnear: [0.0; K],
            dir_x: [0.0; K],
            dir_y: [0.0; K],
            dir_z: [0.0; K],
            time: [0.0; K],
            tfar: [0.0; K],
            mask: [u32::MAX; K],
            id: [0; K],
            flags: [0; K],
            Ng_x: [0.0; K],
            Ng_y: [0.0; K],
            Ng_z: [0.0; K],
            u: [0.0; K],
            v: [0.0; K],
            primID: [INVALID_ID; K],
            geomID: [INVALID_ID; K],
            instID: [[INVALID_ID; K]; 1],
            instPrimID: [[INVALID_ID; K]; 1],
        }
    }
}

/// The `valid` argument of the K-wide calls: `-1` on, `0` off, aligned to the packet size
/// (a misaligned 8-wide mask has been seen to crash the library).
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
pub struct ValidK<const K: usize>(pub [c_int; K]);

/// `struct RTCRayQueryContext` of 4.4 (one instance level, instance arrays on).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct RTCRayQueryContext {
    pub instID: [u32; 1],
    pub instPrimID: [u32; 1],
}

impl Default for RTCRayQueryContext {
    /// `rtcInitRayQueryContext` (inline in the header).
    fn default() -> Self {
        Self {
            instID: [INVALID_ID],
            instPrimID: [INVALID_ID],
        }
    }
}

/// `struct RTCFilterFunctionNArguments`.
#[repr(C)]
pub struct RTCFilterFunctionNArguments {
    pub valid: *mut c_int,
    pub geometryUserPtr: *mut c_void,
    pub context: *mut RTCRayQueryContext,
    /// `struct RTCRayN*`: the ray arrays of an N-wide packet (N given below).
    pub ray: *mut f32,
    /// `struct RTCHitN*`: the hit arrays of an N-wide packet.
    pub hit: *mut f32,
    pub N: c_uint,
}

pub type RTCFilterFunctionN =
    Option<unsafe extern "C" fn(args: *const RTCFilterFunctionNArguments)>;

/// `struct RTCIntersectArguments`, set by hand as `rtcInitIntersectArguments` does. The last
/// field exists only in libraries built with `RTC_MIN_WIDTH`; kept (as 0) so the struct is
/// never shorter than what any build reads.
#[repr(C)]
pub struct RTCIntersectArguments {
    pub flags: c_int,
    pub feature_mask: c_int,
    pub context: *mut RTCRayQueryContext,
    pub filter: RTCFilterFunctionN,
    pub intersect: *mut c_void,
    pub minWidthDistanceFactor: f32,
}

/// `struct RTCOccludedArguments`, set by hand as `rtcInitOccludedArguments` does.
#[repr(C)]
pub struct RTCOccludedArguments {
    pub flags: c_int,
    pub feature_mask: c_int,
    pub context: *mut RTCRayQueryContext,
    pub filter: RTCFilterFunctionN,
    pub occluded: *mut c_void,
    pub minWidthDistanceFactor: f32,
}

impl RTCIntersectArguments {
    pub fn new(flags: c_int) -> Self {
        Self {
            flags,
            feature_mask: FEATURE_FLAG_ALL,
            context: core::ptr::null_mut(),
            filter: None,
            intersect: core::ptr::null_mut(),
            minWidthDistanceFactor: 0.0,
        }
    }
}

impl RTCOccludedArguments {
    pub fn new(flags: c_int) -> Self {
        Self {
            flags,
            feature_mask: FEATURE_FLAG_ALL,
            context: core::ptr::null_mut(),
            filter: None,
            occluded: core::ptr::null_mut(),
            minWidthDistanceFactor: 0.0,
        }
    }
}

/// `typedef bool (*RTCMemoryMonitorFunction)(void* ptr, ssize_t bytes, bool post)`.
pub type RTCMemoryMonitorFunction =
    Option<unsafe extern "C" fn(ptr: *mut c_void, bytes: isize, post: bool) -> bool>;

macro_rules! api {
    ($( $field:ident = $sym:literal : fn($($arg:ty),*) $(-> $ret:ty)? ;)*) => {
        /// The library's entry points, resolved once when it is loaded.
        pub struct Api {
            $( pub $field: unsafe extern "C" fn($($arg),*) $(-> $ret)?, )*
            /// Keeps the library mapped for as long as the pointers above are used.
            _library: libloading::Library,
        }

        impl Api {
            /// Resolves every entry point; the error names the first one missing.
            ///
            /// # Safety
            /// `library` must be an Embree 4 library whose symbols have the signatures above.
            pub unsafe fn resolve(library: libloading::Library) -> Result<Self, String> {
                $(
                    // SAFETY: the caller vouches for the library; the type is the header's.
                    let $field = unsafe {
                        *library
                            .get::<unsafe extern "C" fn($($arg),*) $(-> $ret)?>(
                                concat!($sym, "\0").as_bytes(),
                            )
                            .map_err(|e| format!("symbol {} missing: {e}", $sym))?
                    };
                )*
                Ok(Self { $($field,)* _library: library })
            }
        }
    };
}

api! {
    new_device = "rtcNewDevice": fn(*const c_char) -> RTCDevice;
    release_device = "rtcReleaseDevice": fn(RTCDevice);
    get_device_property = "rtcGetDeviceProperty": fn(RTCDevice, c_int) -> isize;
    get_device_error = "rtcGetDeviceError": fn(RTCDevice) -> c_int;
    get_error_string = "rtcGetErrorString": fn(c_int) -> *const c_char;
    set_device_memory_monitor_function = "rtcSetDeviceMemoryMonitorFunction":
        fn(RTCDevice, RTCMemoryMonitorFunction, *mut c_void);
    new_scene = "rtcNewScene": fn(RTCDevice) -> RTCScene;
    release_scene = "rtcReleaseScene": fn(RTCScene);
    set_scene_build_quality = "rtcSetSceneBuildQuality": fn(RTCScene, c_int);
    set_scene_flags = "rtcSetSceneFlags": fn(RTCScene, c_int);
    attach_geometry_by_id = "rtcAttachGeometryByID": fn(RTCScene, RTCGeometry, c_uint);
    commit_scene = "rtcCommitScene": fn(RTCScene);
    new_geometry = "rtcNewGeometry": fn(RTCDevice, c_int) -> RTCGeometry;
    release_geometry = "rtcReleaseGeometry": fn(RTCGeometry);
    commit_geometry = "rtcCommitGeometry": fn(RTCGeometry);
    set_geometry_build_quality = "rtcSetGeometryBuildQuality": fn(RTCGeometry, c_int);
    set_new_geometry_buffer = "rtcSetNewGeometryBuffer":
        fn(RTCGeometry, c_int, c_uint, c_int, usize, usize) -> *mut c_void;
    set_geometry_instanced_scene = "rtcSetGeometryInstancedScene": fn(RTCGeometry, RTCScene);
    set_geometry_transform = "rtcSetGeometryTransform":
        fn(RTCGeometry, c_uint, c_int, *const c_void);
    intersect1 = "rtcIntersect1": fn(RTCScene, *mut RTCRayHit, *mut RTCIntersectArguments);
    intersect4 = "rtcIntersect4":
        fn(*const c_int, RTCScene, *mut RTCRayHitK<4>, *mut RTCIntersectArguments);
    intersect8 = "rtcIntersect8":
        fn(*const c_int, RTCScene, *mut RTCRayHitK<8>, *mut RTCIntersectArguments);
    intersect16 = "rtcIntersect16":
        fn(*const c_int, RTCScene, *mut RTCRayHitK<16>, *mut RTCIntersectArguments);
    occluded1 = "rtcOccluded1": fn(RTCScene, *mut RTCRay, *mut RTCOccludedArguments);
    occluded4 = "rtcOccluded4":
        fn(*const c_int, RTCScene, *mut RTCRayHitK<4>, *mut RTCOccludedArguments);
    occluded8 = "rtcOccluded8":
        fn(*const c_int, RTCScene, *mut RTCRayHitK<8>, *mut RTCOccludedArguments);
    occluded16 = "rtcOccluded16":
        fn(*const c_int, RTCScene, *mut RTCRayHitK<16>, *mut RTCOccludedArguments);
}
