//! libtorch's CUDA part, loaded at run time, and the facts a record states about a GPU.
//!
//! tch reaches CUDA through libtorch's hooks, which `libtorch_cuda.so` registers when it is
//! loaded; torch-sys links it only where the build's libtorch folder has it, and rustc's default
//! `--as-needed` drops it even then (tch-rs issues 907, 980). Loading it with `dlopen`
//! (`RTLD_GLOBAL`) before libtorch first asks for its hooks has the same effect without a
//! CUDA-specific link. The GPU's name, memory and driver come from the CUDA driver API
//! (`libcuda.so.1`), the runtime's version from the CUDA runtime libtorch loaded.

#![allow(unsafe_code)]

use std::ffi::{CStr, CString, c_char, c_int, c_void};
use std::path::{Path, PathBuf};

/// How to get a CUDA build, for error messages.
pub const HOW_TO_BUILD: &str = "To run on a GPU, prepare libtorch with its CUDA libraries \
    (`JOCA_LIBTORCH=cuda scripts/bootstrap-libtorch.sh`, then `./joca …`), or put a CUDA \
    PyTorch 2.13's `torch/lib` folder on LD_LIBRARY_PATH; see docs/guide/gpu.md";

/// cuBLAS's workspace variable (a fixed workspace makes its reductions repeat).
pub const CUBLAS_WORKSPACE: &str = "CUBLAS_WORKSPACE_CONFIG";

const CUDA_LIB: &str = "libtorch_cuda.so";

/// The last `dlerror` message.
fn dl_error() -> String {
    // SAFETY: dlerror returns null or a NUL-terminated string valid until the next dl call on
    // this thread; it is copied at once.
    let e = unsafe { libc::dlerror() };
    if e.is_null() {
        "unknown loader error".to_owned()
    } else {
        // SAFETY: non-null, NUL-terminated (above).
        unsafe { CStr::from_ptr(e) }.to_string_lossy().into_owned()
    }
}

/// The address of an exported symbol of the process, or null.
fn symbol(name: &str) -> *mut c_void {
    let Ok(name) = CString::new(name) else { return std::ptr::null_mut() };
    // SAFETY: RTLD_DEFAULT searches the global scope; the name is NUL-terminated.
    unsafe { libc::dlsym(libc::RTLD_DEFAULT, name.as_ptr()) }
}

/// The folder of the shared object that defines libtorch's global context (libtorch_cpu.so).
pub fn libtorch_dir() -> Option<PathBuf> {
    let addr = symbol(GLOBAL_CONTEXT);
    if addr.is_null() {
        return None;
    }
    let mut info = std::mem::MaybeUninit::<libc::Dl_info>::zeroed();
    // SAFETY: dladdr fills `info` for an address inside a loaded object and returns non-zero.
    let found = unsafe { libc::dladdr(addr, info.as_mut_ptr()) };
    if found == 0 {
        return None;
    }
    // SAFETY: filled by dladdr (above); dli_fname is NUL-terminated or null.
    let fname = unsafe { info.assume_init() }.dli_fname;
    if fname.is_null() {
        return None;
    }
    // SAFETY: non-null and NUL-terminated (above).
    let path = unsafe { CStr::from_ptr(fname) }.to_string_lossy().into_owned();
    Path::new(&path).parent().map(Path::to_path_buf)
}

fn open(path: &str, flags: c_int) -> Result<*mut c_void, String> {
    let c = CString::new(path).map_err(|e| e.to_string())?;
    // SAFETY: a NUL-terminated path; loading runs the object's initialisers (libtorch's hook
    // registration), which is the point.
    let handle = unsafe { libc::dlopen(c.as_ptr(), flags) };
    if handle.is_null() { Err(dl_error()) } else { Ok(handle) }
}

/// Loads `libtorch_cuda.so` (once; a no-op where the binary links it): first beside the libtorch
/// this process runs, then through the loader's search path. The error gives each try's reason.
pub fn load() -> Result<(), String> {
    // Already loaded (linked, preloaded, or an earlier call): nothing to do.
    if open(CUDA_LIB, libc::RTLD_NOW | libc::RTLD_NOLOAD).is_ok() {
        return Ok(());
    }
    let mut reasons = Vec::new();
    let beside = libtorch_dir().map(|d| d.join(CUDA_LIB));
    let tries = beside.iter().map(|p| p.display().to_string()).chain([CUDA_LIB.to_owned()]);
    for path in tries {
        match open(&path, libc::RTLD_NOW | libc::RTLD_GLOBAL) {
            Ok(_) => return Ok(()),
            Err(why) => reasons.push(why),
        }
    }
    Err(reasons.join("; "))
}

// The CUDA driver API's entry points that describe a device (cuda.h; stable since CUDA 3.2).
type CuInit = unsafe extern "C" fn(c_int) -> c_int;
type CuDeviceGet = unsafe extern "C" fn(*mut c_int, c_int) -> c_int;
type CuDeviceGetName = unsafe extern "C" fn(*mut c_char, c_int, c_int) -> c_int;
type CuDeviceTotalMem = unsafe extern "C" fn(*mut usize, c_int) -> c_int;
type CuVersion = unsafe extern "C" fn(*mut c_int) -> c_int;

/// A CUDA version number (1000·major + 10·minor) as `major.minor`.
pub fn version(v: i32) -> String {
    format!("{}.{}", v / 1000, v % 1000 / 10)
}

/// Looks `name` up in `handle` as a function of type `F` (a function pointer type).
///
/// # Safety
/// `F` must be the symbol's true signature.
unsafe fn function<F: Copy>(handle: *mut c_void, name: &str) -> Option<F> {
    let c = CString::new(name).ok()?;
    // SAFETY: a valid handle and a NUL-terminated name.
    let p = unsafe { libc::dlsym(handle, c.as_ptr()) };
    // SAFETY: the caller guarantees the type; a function pointer is pointer-sized.
    (!p.is_null()).then(|| unsafe { std::mem::transmute_copy::<*mut c_void, F>(&p) })
}

/// GPU `index` as a record states it: name, memory, driver and the CUDA runtime's version, as
/// far as the driver answers (`cuda:0 (facts unavailable: …)` otherwise).
pub fn describe(index: usize) -> String {
    match facts(index) {
        Ok(f) => format!("cuda:{index}: {f}"),
        Err(why) => format!("cuda:{index} (facts unavailable: {why})"),
    }
}

fn facts(index: usize) -> Result<String, String> {
    let lib = open("libcuda.so.1", libc::RTLD_NOW | libc::RTLD_LOCAL)?;
    let ordinal = c_int::try_from(index).map_err(|e| e.to_string())?;
    // SAFETY: each type below is the driver API's documented signature (cuda.h).
    let (init, get, name, mem, driver) = unsafe {
        (
            function::<CuInit>(lib, "cuInit"),
            function::<CuDeviceGet>(lib, "cuDeviceGet"),
            function::<CuDeviceGetName>(lib, "cuDeviceGetName"),
            function::<CuDeviceTotalMem>(lib, "cuDeviceTotalMem_v2"),
            function::<CuVersion>(lib, "cuDriverGetVersion"),
        )
    };
    let missing = || "libcuda.so.1 lacks a driver API entry point".to_owned();
    let (init, get, name, mem, driver) = (
        init.ok_or_else(missing)?,
        get.ok_or_else(missing)?,
        name.ok_or_else(missing)?,
        mem.ok_or_else(missing)?,
        driver.ok_or_else(missing)?,
    );
    let mut dev: c_int = 0;
    let mut buf = [0 as c_char; 256];
    let (mut bytes, mut driver_v) = (0usize, 0 as c_int);
    // SAFETY: driver API calls with valid out-pointers and the buffer's true length.
    let status = unsafe {
        [
            init(0),
            get(&mut dev, ordinal),
            name(buf.as_mut_ptr(), buf.len() as c_int, dev),
            mem(&mut bytes, dev),
            driver(&mut driver_v),
        ]
    };
    if let Some(code) = status.iter().find(|&&s| s != 0) {
        return Err(format!("CUDA driver error {code}"));
    }
    // SAFETY: cuDeviceGetName wrote a NUL-terminated name into the buffer.
    let gpu = unsafe { CStr::from_ptr(buf.as_ptr()) }.to_string_lossy().into_owned();
    let runtime = runtime_version().map_or_else(|| "unknown".to_owned(), version);
    Ok(format!(
        "{gpu}, {:.1} GiB, driver CUDA {}, libtorch's CUDA runtime {runtime}",
        bytes as f64 / f64::from(1u32 << 30),
        version(driver_v)
    ))
}

/// The version of the CUDA runtime libtorch's CUDA part loaded, if it is loaded.
fn runtime_version() -> Option<i32> {
    let p = symbol("cudaRuntimeGetVersion");
    if p.is_null() {
        return None;
    }
    // SAFETY: `cudaError_t cudaRuntimeGetVersion(int*)` (cuda_runtime_api.h).
    let f: CuVersion = unsafe { std::mem::transmute_copy::<*mut c_void, CuVersion>(&p) };
    let mut v: c_int = 0;
    // SAFETY: a valid out-pointer.
    (unsafe { f(&mut v) } == 0).then_some(v)
}

// libtorch's global context (ATen/Context.h): `at::globalContext()` and three of its non-virtual
// members, reached by their Itanium-mangled names (the C API tch binds has no such calls). A
// non-virtual member function takes `this` as its first argument.
const GLOBAL_CONTEXT: &str = "_ZN2at13globalContextEv";
type GlobalContext = unsafe extern "C" fn() -> *mut c_void;
type SetFlags = unsafe extern "C" fn(*mut c_void, bool, bool);
type SetFlag = unsafe extern "C" fn(*mut c_void, bool);
type GetFlag = unsafe extern "C" fn(*mut c_void) -> bool;

fn context() -> Result<*mut c_void, String> {
    let p = symbol(GLOBAL_CONTEXT);
    if p.is_null() {
        return Err(format!("libtorch exports no {GLOBAL_CONTEXT}"));
    }
    // SAFETY: `at::Context& at::globalContext()` returns a reference, passed as a pointer.
    let f: GlobalContext = unsafe { std::mem::transmute_copy::<*mut c_void, GlobalContext>(&p) };
    // SAFETY: no arguments; the context lives as long as the process.
    Ok(unsafe { f() })
}

fn member<F: Copy>(mangled: &str) -> Result<F, String> {
    let p = symbol(mangled);
    if p.is_null() {
        return Err(format!("libtorch exports no {mangled}"));
    }
    // SAFETY: the caller names `F` as the member's signature with `this` first.
    Ok(unsafe { std::mem::transmute_copy::<*mut c_void, F>(&p) })
}

/// Switches libtorch's deterministic algorithms on or off (`warn_only`: an operation without a
/// deterministic kernel warns instead of failing), cuDNN's deterministic mode with it, and
/// cuDNN's autotuner off whenever determinism is on.
pub fn set_deterministic(on: bool) -> Result<(), String> {
    let cx = context()?;
    let algorithms: SetFlags = member("_ZN2at7Context26setDeterministicAlgorithmsEbb")?;
    let cudnn: SetFlag = member("_ZN2at7Context21setDeterministicCuDNNEb")?;
    let benchmark: SetFlag = member("_ZN2at7Context17setBenchmarkCuDNNEb")?;
    // SAFETY: `void at::Context::setDeterministicAlgorithms(bool, bool)`,
    // `setDeterministicCuDNN(bool)` and `setBenchmarkCuDNN(bool)` on the global context.
    unsafe {
        algorithms(cx, on, true);
        cudnn(cx, on);
        if on {
            benchmark(cx, false);
        }
    }
    Ok(())
}

/// Whether libtorch's deterministic algorithms are on.
pub fn deterministic() -> Result<bool, String> {
    let cx = context()?;
    let get: GetFlag = member("_ZNK2at7Context23deterministicAlgorithmsEv")?;
    // SAFETY: `bool at::Context::deterministicAlgorithms() const` on the global context.
    Ok(unsafe { get(cx) })
}
