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
    let model = fmu::InterfaceFmu::create(None).unwrap();
    std::ffi::CString::new(fmu::InterfaceFmu::info(None, &model).unwrap().instantiation_token).unwrap()
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

/// Without the test harness: the counting allocator sees every thread of the process, and the
/// harness's own thread allocates at unpredictable moments.
fn main() {
    the_c_abis_refuse_bad_calls_and_leak_nothing();
    println!("the C ABIs refuse bad calls and leak nothing: ok");
}

fn the_c_abis_refuse_bad_calls_and_leak_nothing() {
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
        // Step sizes with float noise (as a master accumulating time in floats sends them) give
        // the same whole number of micro steps: 0.009999999999999998 s is 1000 steps of 1e-5 s,
        // and ten steps between float-accumulated points of 0.001 s are 100 each.
        let step = |t: f64, h: f64| {
            let null = std::ptr::null_mut();
            fmi3DoStep(i, t, h, false, null, null, null, std::ptr::null_mut())
        };
        let mut t = 1e-5;
        assert_eq!(step(t, 0.009999999999999998), 0);
        t += 0.009999999999999998;
        for _ in 0..10 {
            let next = t + 0.001;
            assert_eq!(step(t, next - t), 0);
            t = next;
        }
        let mut micro_steps = [0.0];
        let vr = [lash_micro::vr::MICRO_STEPS];
        assert_eq!(fmi3GetFloat64(i, vr.as_ptr(), 1, micro_steps.as_mut_ptr(), 1), 0);
        assert_eq!(micro_steps[0], (1 + 1000 + 10 * 100) as f64, "noisy step sizes changed the micro-step count");
        fmi3FreeInstance(i);
    }
    fmi2_refuses_bad_calls_and_round_trips_array_elements();
    // 10 000 instantiate/initialise/step/free cycles leave no memory behind.
    let region = Region::new(GLOBAL);
    for _ in 0..10_000 {
        let i = instantiate(token.as_ptr());
        // SAFETY: a live instance, freed once.
        unsafe {
            assert_eq!(fmu::fmi3_exports::fmi3EnterInitializationMode(i, false, 0.0, 0.0, false, 0.0), 0);
            assert_eq!(fmu::fmi3_exports::fmi3ExitInitializationMode(i), 0);
            let null = std::ptr::null_mut();
            assert_eq!(fmu::fmi3_exports::fmi3DoStep(i, 0.0, 1e-5, false, null, null, null, std::ptr::null_mut()), 0);
            fmu::fmi3_exports::fmi3FreeInstance(i);
        }
    }
    let stats = region.change();
    assert_eq!(stats.bytes_allocated as i64 - stats.bytes_deallocated as i64, 0, "{stats:?}");
    // The same through the FMI 2.0 functions (with their extra per-instance scalar table).
    let region = Region::new(GLOBAL);
    for _ in 0..10_000 {
        use fmu::fmi2_exports::*;
        // SAFETY: a live instance, freed once; null callbacks are accepted.
        unsafe {
            let c = fmi2Instantiate(c"x".as_ptr(), 1, token.as_ptr(), std::ptr::null(), std::ptr::null(), 0, 0);
            assert!(!c.is_null());
            assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), 0);
            assert_eq!(fmi2EnterInitializationMode(c), 0);
            assert_eq!(fmi2ExitInitializationMode(c), 0);
            assert_eq!(fmi2DoStep(c, 0.0, 1e-5, 1), 0);
            fmi2FreeInstance(c);
        }
    }
    let stats = region.change();
    assert_eq!(stats.bytes_allocated as i64 - stats.bytes_deallocated as i64, 0, "FMI 2.0: {stats:?}");
}

/// FMI 2.0 over the same instances (run from the test above: the allocation count of that test
/// must not see another test's allocations).
fn fmi2_refuses_bad_calls_and_round_trips_array_elements() {
    use fmu::fmi2_exports::*;
    let token = token();
    // SAFETY: null and valid pointers as the FMI 2.0 functions expect; each instance freed once.
    unsafe {
        let me = fmi2Instantiate(c"x".as_ptr(), 0, token.as_ptr(), std::ptr::null(), std::ptr::null(), 0, 0);
        assert!(me.is_null(), "model exchange is refused");
        let bad = fmi2Instantiate(c"x".as_ptr(), 1, c"{nope}".as_ptr(), std::ptr::null(), std::ptr::null(), 0, 0);
        assert!(bad.is_null(), "a wrong GUID is refused");
        assert_eq!(fmi2DoStep(std::ptr::null_mut(), 0.0, 1e-5, 1), 3);
        let c = fmi2Instantiate(c"x".as_ptr(), 1, token.as_ptr(), std::ptr::null(), std::ptr::null(), 0, 0);
        assert!(!c.is_null());
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 1, 0.01), 0);
        // Element [2,2] of the 2×2 effective mass is scalar 3 (row-major, numbered from 0).
        let (vr, value) = ([3u32], [0.25]);
        assert_eq!(fmi2SetReal(c, vr.as_ptr(), 1, value.as_ptr()), 0, "set before initialisation");
        assert_eq!(fmi2EnterInitializationMode(c), 0);
        assert_eq!(fmi2ExitInitializationMode(c), 0);
        let vrs = [0u32, 1, 2, 3];
        let mut m = [0.0; 4];
        assert_eq!(fmi2GetReal(c, vrs.as_ptr(), 4, m.as_mut_ptr()), 0);
        assert_eq!(m, [1.0, 0.0, 0.0, 0.25], "one element changed, the others kept their start values");
        assert_eq!(fmi2DoStep(c, 0.0, 1e-5, 1), 0);
        let out = [100_000u32];
        assert_eq!(fmi2GetReal(c, out.as_ptr(), 1, m.as_mut_ptr()), 3, "unknown value reference");
        assert_eq!(fmi2GetInteger(c), 3, "unsupported functions answer fmi2Error");
        assert_eq!(fmi2Terminate(c), 0);
        fmi2FreeInstance(c);
    }
}
