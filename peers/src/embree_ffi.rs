//! A minimal binding to Embree 3 (Debian's `libembree-dev`, 3.13.x): just what a closest-hit and
//! occlusion comparison over one triangle mesh needs.
//!
//! Why not the crates.io `embree` crate (0.3.8)? It does target Embree 3 and links `embree3`, but
//! its safe `Device::new()` hard-codes a null configuration string, so the BVH build always runs on
//! every core (no `threads=1`), and it offers no way to set the build quality without dropping to
//! its raw `sys` module anyway. The dozen declarations below are simpler to audit.
//!
//! Layouts follow `/usr/include/embree3/rtcore_ray.h` and `rtcore_common.h` with
//! `RTC_MAX_INSTANCE_LEVEL_COUNT == 1` and `RTC_MIN_WIDTH == 0` (Debian's build); the `const`
//! assertions at the bottom pin the sizes and offsets a C compiler reports for that header.

#![allow(non_camel_case_types, non_snake_case)]

use std::ffi::{CStr, CString, c_char, c_uint, c_void};
use std::marker::PhantomData;
use std::mem::{align_of, offset_of, size_of};
use std::ptr::NonNull;

use raybatch::glam::Vec3;

// ---------------------------------------------------------------------------------------------
// Raw C API
// ---------------------------------------------------------------------------------------------

#[repr(C)]
pub struct RTCDeviceTy {
    _private: [u8; 0],
}
#[repr(C)]
pub struct RTCSceneTy {
    _private: [u8; 0],
}
#[repr(C)]
pub struct RTCGeometryTy {
    _private: [u8; 0],
}
pub type RTCDevice = *mut RTCDeviceTy;
pub type RTCScene = *mut RTCSceneTy;
pub type RTCGeometry = *mut RTCGeometryTy;

/// C enums are `int`-sized; they are passed as plain integers.
pub type RTCError = c_uint;
pub type RTCDeviceProperty = c_uint;
pub type RTCGeometryType = c_uint;
pub type RTCBufferType = c_uint;
pub type RTCFormat = c_uint;
pub type RTCBuildQuality = c_uint;
pub type RTCSceneFlags = c_uint;
pub type RTCIntersectContextFlags = c_uint;

pub const RTC_ERROR_NONE: RTCError = 0;
pub const RTC_DEVICE_PROPERTY_VERSION: RTCDeviceProperty = 0;
pub const RTC_DEVICE_PROPERTY_TASKING_SYSTEM: RTCDeviceProperty = 128;
pub const RTC_GEOMETRY_TYPE_TRIANGLE: RTCGeometryType = 0;
pub const RTC_BUFFER_TYPE_INDEX: RTCBufferType = 0;
pub const RTC_BUFFER_TYPE_VERTEX: RTCBufferType = 1;
pub const RTC_FORMAT_UINT3: RTCFormat = 0x5003;
pub const RTC_FORMAT_FLOAT3: RTCFormat = 0x9003;
pub const RTC_BUILD_QUALITY_LOW: RTCBuildQuality = 0;
pub const RTC_BUILD_QUALITY_MEDIUM: RTCBuildQuality = 1;
pub const RTC_BUILD_QUALITY_HIGH: RTCBuildQuality = 2;
pub const RTC_SCENE_FLAG_NONE: RTCSceneFlags = 0;
/// Avoids optimizations that reduce arithmetic accuracy (Embree 3's `RTC_SCENE_FLAG_ROBUST`).
pub const RTC_SCENE_FLAG_ROBUST: RTCSceneFlags = 1 << 2;
pub const RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT: RTCIntersectContextFlags = 0;
pub const RTC_INVALID_GEOMETRY_ID: c_uint = u32::MAX;

/// `struct RTC_ALIGN(16) RTCRay`.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
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
    pub mask: c_uint,
    pub id: c_uint,
    pub flags: c_uint,
}

/// `struct RTC_ALIGN(16) RTCHit` (one instance level).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RTCHit {
    pub Ng_x: f32,
    pub Ng_y: f32,
    pub Ng_z: f32,
    pub u: f32,
    pub v: f32,
    pub primID: c_uint,
    pub geomID: c_uint,
    pub instID: [c_uint; 1],
}

/// `struct RTCRayHit` (16-byte aligned through its members).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RTCRayHit {
    pub ray: RTCRay,
    pub hit: RTCHit,
}

pub type RTCFilterFunctionN = Option<unsafe extern "C" fn(args: *const c_void)>;

/// `struct RTCIntersectContext` (one instance level, no `instStackSize`, no min-width factor).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct RTCIntersectContext {
    pub flags: RTCIntersectContextFlags,
    pub filter: RTCFilterFunctionN,
    pub instID: [c_uint; 1],
}

pub type RTCErrorFunction =
    Option<unsafe extern "C" fn(user_ptr: *mut c_void, code: RTCError, message: *const c_char)>;

#[link(name = "embree3")]
unsafe extern "C" {
    pub fn rtcNewDevice(config: *const c_char) -> RTCDevice;
    pub fn rtcReleaseDevice(device: RTCDevice);
    pub fn rtcGetDeviceProperty(device: RTCDevice, prop: RTCDeviceProperty) -> isize;
    pub fn rtcGetDeviceError(device: RTCDevice) -> RTCError;
    pub fn rtcSetDeviceErrorFunction(device: RTCDevice, error: RTCErrorFunction, user: *mut c_void);

    pub fn rtcNewScene(device: RTCDevice) -> RTCScene;
    pub fn rtcReleaseScene(scene: RTCScene);
    pub fn rtcSetSceneFlags(scene: RTCScene, flags: RTCSceneFlags);
    pub fn rtcSetSceneBuildQuality(scene: RTCScene, quality: RTCBuildQuality);
    pub fn rtcAttachGeometry(scene: RTCScene, geometry: RTCGeometry) -> c_uint;
    pub fn rtcCommitScene(scene: RTCScene);

    pub fn rtcNewGeometry(device: RTCDevice, kind: RTCGeometryType) -> RTCGeometry;
    pub fn rtcReleaseGeometry(geometry: RTCGeometry);
    pub fn rtcSetGeometryBuildQuality(geometry: RTCGeometry, quality: RTCBuildQuality);
    pub fn rtcSetSharedGeometryBuffer(
        geometry: RTCGeometry,
        kind: RTCBufferType,
        slot: c_uint,
        format: RTCFormat,
        ptr: *const c_void,
        byte_offset: usize,
        byte_stride: usize,
        item_count: usize,
    );
    pub fn rtcSetNewGeometryBuffer(
        geometry: RTCGeometry,
        kind: RTCBufferType,
        slot: c_uint,
        format: RTCFormat,
        byte_stride: usize,
        item_count: usize,
    ) -> *mut c_void;
    pub fn rtcCommitGeometry(geometry: RTCGeometry);

    pub fn rtcIntersect1(
        scene: RTCScene,
        context: *mut RTCIntersectContext,
        rayhit: *mut RTCRayHit,
    );
    pub fn rtcIntersect1M(
        scene: RTCScene,
        context: *mut RTCIntersectContext,
        rayhit: *mut RTCRayHit,
        m: c_uint,
        byte_stride: usize,
    );
    pub fn rtcOccluded1(scene: RTCScene, context: *mut RTCIntersectContext, ray: *mut RTCRay);
}

/// `rtcInitIntersectContext` is `RTC_FORCEINLINE` in the header (no symbol): its body, for one
/// instance level.
pub fn rtc_init_intersect_context() -> RTCIntersectContext {
    RTCIntersectContext {
        flags: RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
        filter: None,
        instID: [RTC_INVALID_GEOMETRY_ID],
    }
}

// Sizes and offsets as gcc reports them for Debian's embree3 3.13.5 headers.
const _: () = {
    assert!(size_of::<RTCRay>() == 48 && align_of::<RTCRay>() == 16);
    assert!(offset_of!(RTCRay, tnear) == 12);
    assert!(offset_of!(RTCRay, tfar) == 32);
    assert!(offset_of!(RTCRay, flags) == 44);
    assert!(size_of::<RTCHit>() == 32 && align_of::<RTCHit>() == 16);
    assert!(offset_of!(RTCHit, primID) == 20);
    assert!(offset_of!(RTCHit, instID) == 28);
    assert!(size_of::<RTCRayHit>() == 80 && align_of::<RTCRayHit>() == 16);
    assert!(offset_of!(RTCRayHit, hit) == 48);
    assert!(size_of::<RTCIntersectContext>() == 24 && align_of::<RTCIntersectContext>() == 8);
    assert!(offset_of!(RTCIntersectContext, filter) == 8);
    assert!(offset_of!(RTCIntersectContext, instID) == 16);
};

// ---------------------------------------------------------------------------------------------
// Safe wrapper
// ---------------------------------------------------------------------------------------------

impl RTCRay {
    /// A ray `origin + t * dir`, `t` in `[tnear, tfar]`, all mask bits set.
    pub fn new(origin: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Self {
        Self {
            org_x: origin.x,
            org_y: origin.y,
            org_z: origin.z,
            tnear,
            dir_x: dir.x,
            dir_y: dir.y,
            dir_z: dir.z,
            time: 0.0,
            tfar,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }
}

impl RTCHit {
    /// "No hit yet": `geomID` must be `RTC_INVALID_GEOMETRY_ID` before `rtcIntersect*`.
    pub const NONE: Self = Self {
        Ng_x: 0.0,
        Ng_y: 0.0,
        Ng_z: 0.0,
        u: 0.0,
        v: 0.0,
        primID: RTC_INVALID_GEOMETRY_ID,
        geomID: RTC_INVALID_GEOMETRY_ID,
        instID: [RTC_INVALID_GEOMETRY_ID],
    };
}

impl RTCRayHit {
    pub fn new(ray: RTCRay) -> Self {
        Self {
            ray,
            hit: RTCHit::NONE,
        }
    }

    /// `(tfar, primID)` if the ray hit something.
    pub fn closest(&self) -> Option<(f32, u32)> {
        (self.hit.geomID != RTC_INVALID_GEOMETRY_ID).then_some((self.ray.tfar, self.hit.primID))
    }
}

fn take_error(device: RTCDevice, what: &str) -> Result<(), String> {
    // SAFETY: `device` is a live device handle.
    let code = unsafe { rtcGetDeviceError(device) };
    if code == RTC_ERROR_NONE {
        Ok(())
    } else {
        Err(format!("embree: {what} failed with RTCError {code}"))
    }
}

unsafe extern "C" fn print_error(_user: *mut c_void, code: RTCError, message: *const c_char) {
    let text = if message.is_null() {
        String::new()
    } else {
        // SAFETY: Embree passes a NUL-terminated string that lives for the call.
        unsafe { CStr::from_ptr(message) }
            .to_string_lossy()
            .into_owned()
    };
    eprintln!("embree error {code}: {text}");
}

/// An Embree device (owns the handle).
pub struct Device {
    handle: NonNull<RTCDeviceTy>,
}

impl Device {
    /// `rtcNewDevice(config)`, e.g. `"threads=1"`. Errors are also printed to stderr as they occur.
    pub fn new(config: &str) -> Result<Self, String> {
        let config = CString::new(config).map_err(|e| e.to_string())?;
        // SAFETY: a valid NUL-terminated string; a null result is handled.
        let raw = unsafe { rtcNewDevice(config.as_ptr()) };
        let handle = NonNull::new(raw).ok_or_else(|| {
            // SAFETY: the null device reports the creation error.
            let code = unsafe { rtcGetDeviceError(std::ptr::null_mut()) };
            format!("rtcNewDevice failed with RTCError {code}")
        })?;
        // SAFETY: live device; the callback is a plain function with no user data.
        unsafe {
            rtcSetDeviceErrorFunction(handle.as_ptr(), Some(print_error), std::ptr::null_mut())
        };
        Ok(Self { handle })
    }

    fn raw(&self) -> RTCDevice {
        self.handle.as_ptr()
    }

    /// `RTC_DEVICE_PROPERTY_VERSION`, e.g. 31305 for 3.13.5.
    pub fn version(&self) -> isize {
        // SAFETY: live device.
        unsafe { rtcGetDeviceProperty(self.raw(), RTC_DEVICE_PROPERTY_VERSION) }
    }

    /// "3.13.5" from [`Device::version`].
    pub fn version_string(&self) -> String {
        let v = self.version();
        format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100)
    }

    /// The tasking system Embree was built with: 0 internal, 1 TBB, 2 PPL.
    pub fn tasking_system(&self) -> &'static str {
        // SAFETY: live device.
        match unsafe { rtcGetDeviceProperty(self.raw(), RTC_DEVICE_PROPERTY_TASKING_SYSTEM) } {
            0 => "internal",
            1 => "TBB",
            2 => "PPL",
            _ => "unknown",
        }
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: the handle is ours; scenes borrow the device, so they are gone already.
        unsafe { rtcReleaseDevice(self.raw()) }
    }
}

/// A committed scene holding one triangle mesh (geometry id 0; `primID` is the triangle index).
pub struct Scene<'d> {
    handle: NonNull<RTCSceneTy>,
    _device: PhantomData<&'d Device>,
}

impl<'d> Scene<'d> {
    /// Copies the mesh into Embree-owned buffers (`rtcSetNewGeometryBuffer` over-allocates the
    /// vertex buffer so the last float3 can be read with a 16-byte load), builds with `quality`
    /// for both the geometry and the scene, with scene `flags`, and commits.
    pub fn triangles(
        device: &'d Device,
        vertices: &[Vec3],
        triangles: &[[u32; 3]],
        quality: RTCBuildQuality,
        flags: RTCSceneFlags,
    ) -> Result<Self, String> {
        let dev = device.raw();
        // SAFETY: every call gets live handles; the buffers returned by rtcSetNewGeometryBuffer
        // hold exactly `count * stride` bytes (plus padding), which is what we write.
        unsafe {
            let geometry = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
            if geometry.is_null() {
                take_error(dev, "rtcNewGeometry")?;
                return Err("rtcNewGeometry returned null".into());
            }
            rtcSetGeometryBuildQuality(geometry, quality);
            let vb = rtcSetNewGeometryBuffer(
                geometry,
                RTC_BUFFER_TYPE_VERTEX,
                0,
                RTC_FORMAT_FLOAT3,
                3 * size_of::<f32>(),
                vertices.len(),
            ) as *mut f32;
            let ib = rtcSetNewGeometryBuffer(
                geometry,
                RTC_BUFFER_TYPE_INDEX,
                0,
                RTC_FORMAT_UINT3,
                3 * size_of::<u32>(),
                triangles.len(),
            ) as *mut u32;
            if vb.is_null() || ib.is_null() {
                rtcReleaseGeometry(geometry);
                take_error(dev, "rtcSetNewGeometryBuffer")?;
                return Err("rtcSetNewGeometryBuffer returned null".into());
            }
            let vb = std::slice::from_raw_parts_mut(vb, 3 * vertices.len());
            for (dst, v) in vb.chunks_exact_mut(3).zip(vertices) {
                dst.copy_from_slice(&v.to_array());
            }
            let ib = std::slice::from_raw_parts_mut(ib, 3 * triangles.len());
            for (dst, t) in ib.chunks_exact_mut(3).zip(triangles) {
                dst.copy_from_slice(t);
            }
            rtcCommitGeometry(geometry);

            let scene = rtcNewScene(dev);
            let Some(handle) = NonNull::new(scene) else {
                rtcReleaseGeometry(geometry);
                take_error(dev, "rtcNewScene")?;
                return Err("rtcNewScene returned null".into());
            };
            let scene = Self {
                handle,
                _device: PhantomData,
            };
            rtcSetSceneFlags(scene.raw(), flags);
            rtcSetSceneBuildQuality(scene.raw(), quality);
            let id = rtcAttachGeometry(scene.raw(), geometry);
            // The scene holds its own reference now.
            rtcReleaseGeometry(geometry);
            if id != 0 {
                return Err(format!("embree: geometry got id {id}, expected 0"));
            }
            rtcCommitScene(scene.raw());
            take_error(dev, "scene build")?;
            Ok(scene)
        }
    }

    fn raw(&self) -> RTCScene {
        self.handle.as_ptr()
    }

    /// `rtcIntersect1`: closest hit, written into `rayhit` (`ray.tfar` and `hit`).
    #[inline]
    pub fn intersect1(&self, context: &mut RTCIntersectContext, rayhit: &mut RTCRayHit) {
        // SAFETY: committed scene, valid context and ray/hit pointers for the call.
        unsafe { rtcIntersect1(self.raw(), context, rayhit) }
    }

    /// `rtcIntersect1M` over a contiguous array (stride `size_of::<RTCRayHit>()`), in chunks
    /// that fit the `unsigned int` count.
    pub fn intersect1m(&self, context: &mut RTCIntersectContext, rayhits: &mut [RTCRayHit]) {
        for chunk in rayhits.chunks_mut(1 << 30) {
            // SAFETY: as above; `chunk.len()` elements of the stated stride are valid.
            unsafe {
                rtcIntersect1M(
                    self.raw(),
                    context,
                    chunk.as_mut_ptr(),
                    chunk.len() as c_uint,
                    size_of::<RTCRayHit>(),
                )
            }
        }
    }

    /// `rtcOccluded1`: true if anything is hit in `[tnear, tfar]` (Embree sets `tfar = -inf`).
    #[inline]
    pub fn occluded1(&self, context: &mut RTCIntersectContext, ray: &RTCRay) -> bool {
        let mut ray = *ray;
        // SAFETY: committed scene, valid context and ray pointers for the call.
        unsafe { rtcOccluded1(self.raw(), context, &mut ray) };
        ray.tfar == f32::NEG_INFINITY
    }
}

impl Drop for Scene<'_> {
    fn drop(&mut self) {
        // SAFETY: the handle is ours.
        unsafe { rtcReleaseScene(self.raw()) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad_scene(device: &Device) -> Scene<'_> {
        let v = [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        ];
        Scene::triangles(
            device,
            &v,
            &[[0, 1, 2], [0, 2, 3]],
            RTC_BUILD_QUALITY_HIGH,
            RTC_SCENE_FLAG_NONE,
        )
        .unwrap()
    }

    #[test]
    fn intersect_occlude_and_stream_agree_on_a_quad() {
        let device = Device::new("threads=1").unwrap();
        assert_eq!(device.version() / 10000, 3);
        let scene = quad_scene(&device);
        let mut ctx = rtc_init_intersect_context();

        let hit_ray = RTCRay::new(Vec3::new(0.7, 0.2, 0.0), Vec3::Z * 2.0, 0.0, f32::INFINITY);
        let mut rh = RTCRayHit::new(hit_ray);
        scene.intersect1(&mut ctx, &mut rh);
        let (t, prim) = rh.closest().unwrap();
        assert!((t - 0.5).abs() < 1e-6 && prim == 0, "{rh:?}");
        assert!(
            (rh.hit.u - 0.5).abs() < 1e-6 && (rh.hit.v - 0.2).abs() < 1e-6,
            "{rh:?}"
        );

        let other = RTCRay::new(Vec3::new(0.2, 0.7, 0.0), Vec3::Z, 0.0, f32::INFINITY);
        let miss = RTCRay::new(Vec3::new(2.0, 0.5, 0.0), Vec3::Z, 0.0, f32::INFINITY);
        let short = RTCRay::new(Vec3::new(0.2, 0.7, 0.0), Vec3::Z, 0.0, 0.5);
        assert!(scene.occluded1(&mut ctx, &other));
        assert!(!scene.occluded1(&mut ctx, &miss));
        assert!(!scene.occluded1(&mut ctx, &short));

        let mut stream: Vec<RTCRayHit> = [hit_ray, other, miss, short]
            .into_iter()
            .map(RTCRayHit::new)
            .collect();
        scene.intersect1m(&mut ctx, &mut stream);
        let got: Vec<_> = stream.iter().map(|r| r.closest().map(|(_, p)| p)).collect();
        assert_eq!(got, [Some(0), Some(1), None, None]);
    }
}
