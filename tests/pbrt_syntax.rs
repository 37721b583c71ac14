//! The pbrt-v4 reader's first stage on Bitterli's scenes in `../shared/scenes/pbrt-v4`: every
//! file reads into directives (the syntax of real research scenes, not only of our fixtures).

mod common;

use pathtracer::io::pbrt::{read_file, Arg};

#[test]
fn bitterlis_scenes_read_into_directives() {
    let Some(shared) = common::shared() else {
        return;
    };
    let dir = shared.join("scenes/pbrt-v4");
    let mut scenes = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let file = entry.unwrap().path().join("scene-v4.pbrt");
        if !file.is_file() {
            continue;
        }
        let d = read_file(&file).unwrap_or_else(|e| panic!("{e}"));
        let count = |name: &str| d.iter().filter(|x| x.name == name).count();
        assert_eq!(count("WorldBegin"), 1, "{}", file.display());
        assert!(
            count("Shape") > 0 && count("Camera") == 1,
            "{}",
            file.display()
        );
        let begins = count("AttributeBegin");
        assert_eq!(begins, count("AttributeEnd"), "{}", file.display());
        // Every shape names its kind.
        assert!(d
            .iter()
            .filter(|x| x.name == "Shape")
            .all(|x| matches!(x.args.first(), Some(Arg::Str(_)))));
        scenes += 1;
    }
    assert!(
        scenes >= 3,
        "found {scenes} pbrt-v4 scenes in {}",
        dir.display()
    );
}
