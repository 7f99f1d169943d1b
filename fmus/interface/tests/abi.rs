//! The FMU's C ABI exercised in-process: null pointers, a wrong token, calls out of order,
//! unsupported functions, float noise on the communication point, and no leaks over 10 000
//! instantiations (counting allocator).

use std::ffi::{c_char, c_void};

use lash_interface as fmu;
use stats_alloc::{INSTRUMENTED_SYSTEM, Region, StatsAlloc};
use std::alloc::System;

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

fn token() -> std::ffi::CString {
    use lash_fmi::fmi3::Exportable;
    std::ffi::CString::new(fmu::InterfaceFmu::info().instantiation_token).unwrap()
}

fn instantiate(token: *const c_char) -> *mut c_void {
    // SAFETY: valid C strings (or null), no logger.
    unsafe {
        fmu::fmi3_exports::fmi3InstantiateCoSimulation(
            c"test".as_ptr(),
            token,
            std::ptr::null(),
            false,
            false,
            false,
            false,
            std::ptr::null(),
            0,
            std::ptr::null_mut(),
            None,
            std::ptr::null(),
        )
    }
}

#[test]
fn the_c_abi_refuses_bad_calls_and_leaks_nothing() {
    use fmu::fmi3_exports::*;
    let token = token();
    assert!(instantiate(c"{wrong}".as_ptr()).is_null(), "a wrong instantiation token is refused");
    assert!(instantiate(std::ptr::null()).is_null(), "a null token is refused");
    // SAFETY: null instances and null arrays are what is being tested; the functions check them.
    unsafe {
        assert_eq!(
            fmi3DoStep(
                std::ptr::null_mut(),
                0.0,
                1e-5,
                false,
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                std::ptr::null_mut()
            ),
            3
        );
        let i = instantiate(token.as_ptr());
        assert!(!i.is_null());
        assert_eq!(
            fmi3DoStep(
                i,
                0.0,
                1e-5,
                false,
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                std::ptr::null_mut()
            ),
            3,
            "doStep before initialisation"
        );
        assert_eq!(fmi3GetFloat64(i, std::ptr::null(), 1, std::ptr::null_mut(), 1), 3, "null arrays");
        assert_eq!(fmi3EnterInitializationMode(i, false, 0.0, 0.0, false, 0.0), 0);
        assert_eq!(fmi3ExitInitializationMode(i), 0);
        let vr = [99u32];
        let mut v = [0.0];
        assert_eq!(fmi3GetFloat64(i, vr.as_ptr(), 1, v.as_mut_ptr(), 1), 3, "unknown value reference");
        assert_eq!(fmi3GetClock(i), 3, "unsupported functions answer fmi3Error");
        assert_eq!(
            fmi3DoStep(
                i,
                0.009999999999999998 - 0.01,
                1e-5,
                false,
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                std::ptr::null_mut()
            ),
            0,
            "float noise on the communication point"
        );
        fmi3FreeInstance(i);
    }
    // 10 000 instantiate/initialise/step/free cycles leave no memory behind.
    let region = Region::new(GLOBAL);
    for _ in 0..10_000 {
        let i = instantiate(token.as_ptr());
        // SAFETY: a live instance, freed once.
        unsafe {
            assert_eq!(fmu::fmi3_exports::fmi3EnterInitializationMode(i, false, 0.0, 0.0, false, 0.0), 0);
            assert_eq!(fmu::fmi3_exports::fmi3ExitInitializationMode(i), 0);
            fmu::fmi3_exports::fmi3FreeInstance(i);
        }
    }
    let stats = region.change();
    assert_eq!(stats.bytes_allocated as i64 - stats.bytes_deallocated as i64, 0, "{stats:?}");
}
