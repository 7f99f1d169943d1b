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

/// The name and reference checks that planar and spatial files share (one source): a body or
/// sensor named twice, a joint or sensor on a body that is not there, an output channel that does
/// not exist — each names its field, in either kind of file.
#[test]
fn repeated_names_and_missing_bodies_are_named_in_planar_and_spatial_files() {
    let mut a = lash_scenario::builtin::by_name("A").unwrap();
    a.bodies[1].name = a.bodies[0].name.clone();
    a.joints[0].body2 = "nowhere".into();
    a.sensors.push(a.sensors[0].clone());
    a.output.channels = vec!["no_such.channel".into()];
    let planar = lash_scenario::validate(&a).to_string();
    let mut e = lash_scenario::builtin_spatial::spatial_by_name("E").unwrap();
    e.bodies[1].name = e.bodies[0].name.clone();
    e.joints[0].body2 = "nowhere".into();
    e.sensors.push(e.sensors[0].clone());
    e.output.channels = vec!["no_such.channel".into()];
    let spatial = lash_scenario::validate_spatial(&e).to_string();
    for text in [planar, spatial] {
        for wanted in [
            "bodies[1].name",
            "is used by another body",
            "joints[0].body2",
            "no body called \"nowhere\"",
            "is used by another sensor",
            "output.channels[0]",
            "no channel called \"no_such.channel\"",
        ] {
            assert!(text.contains(wanted), "{wanted:?} not in {text}");
        }
    }
}

/// An oil film is a planar revolute joint's: on a spherical clearance joint it is refused, named.
#[test]
fn a_film_on_a_spherical_joint_is_refused_by_name() {
    let mut e = lash_scenario::builtin_spatial::spatial_by_name("E").unwrap();
    e.clearances[1].film = lash_scenario::builtin::by_name("A-lubricated").unwrap().clearances[0].film;
    let p = lash_scenario::validate_spatial(&e).to_string();
    assert!(p.contains("clearances[1].film") && p.contains("spherical"), "{p}");
}
