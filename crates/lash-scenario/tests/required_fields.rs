//! Fields that change the physics are never filled in silently: a sensor or load without its
//! point, a clearance joint without its friction block are errors naming the field; a negative
//! harmonic frequency is refused.

/// Scenario A as its file, with `edit` applied to the text.
fn a_with(edit: impl Fn(String) -> String) -> Result<lash_scenario::Scenario, String> {
    let a = lash_scenario::builtin::by_name("A").unwrap();
    let text = edit(toml::to_string(&a).unwrap());
    lash_scenario::parse(&text).map_err(|p| p.to_string())
}

#[test]
fn a_forgotten_point_or_friction_block_is_an_error_naming_it() {
    assert!(a_with(|t| t).is_ok());
    let e = a_with(|t| {
        let sensor = "name = \"slider\"\nbody = \"slider\"\npoint = [0.0, 0.0]\n";
        assert!(t.contains(sensor), "{t}");
        t.replace(sensor, "name = \"slider\"\nbody = \"slider\"\n")
    })
    .unwrap_err();
    assert!(e.contains("sensors[0]") && e.contains("point") && e.contains("missing"), "{e}");
    let friction = "[clearances.friction]\nlaw = \"ambrosio\"\ncoefficient = 0.01\nv0 = 0.0001\nv1 = 0.001\n";
    let e = a_with(|t| {
        assert!(t.contains(friction), "{t}");
        t.replace(friction, "")
    })
    .unwrap_err();
    assert!(e.contains("clearances[0]") && e.contains("friction") && e.contains("missing"), "{e}");
    let frictionless = a_with(|t| t.replace(friction, "[clearances.friction]\nlaw = \"none\"\n"));
    assert!(frictionless.is_ok(), "law = \"none\" says it: {frictionless:?}");
}

#[test]
fn a_negative_harmonic_frequency_is_refused() {
    let harmonic = |f: f64| {
        a_with(move |t| {
            let speed = "type = \"constant_speed\"\nangle0 = 0.0\nomega = 523.5987755982989";
            assert!(t.contains(speed), "{t}");
            t.replace(
                speed,
                &format!("type = \"harmonic\"\nangle0 = 0.0\nomega = 523.5987755982989\namplitude = 0.1\nfrequency = {f:?}\nphase = 0.0"),
            )
        })
    };
    assert!(harmonic(50.0).is_ok(), "{:?}", harmonic(50.0));
    let e = harmonic(-50.0).unwrap_err();
    assert!(e.contains("drivers[0].motion.frequency"), "{e}");
}
