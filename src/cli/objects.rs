//! `--object SCENE[:TX,TY,TZ[,RX,RY,RZ[,S]]]` of `render` and `sweep`: several splat objects
//! in one frame (SPEC section 9), each with a transform, drawn by `Renderer::record_objects`.

use std::path::PathBuf;

use glam::{Quat, Vec3};

use rara::objects::ObjectTransform;
use rara::{Error, Result, Scene};

/// One `--object`: a scene file and its transform.
#[derive(Clone, Debug)]
pub struct ObjectArg {
    /// The scene file.
    pub path: PathBuf,
    /// Its transform.
    pub transform: ObjectTransform,
}

/// Parses `SCENE[:TX,TY,TZ[,RX,RY,RZ[,S]]]`: a translation, rotations in degrees about x, then
/// y, then z (of the world's axes), and a uniform scale.
pub fn parse_object(s: &str) -> std::result::Result<ObjectArg, String> {
    let (path, numbers) = match s.rsplit_once(':') {
        Some((p, t)) if !p.is_empty() && t.split(',').all(|v| v.trim().parse::<f32>().is_ok()) => {
            (p, Some(t))
        }
        _ => (s, None),
    };
    let mut transform = ObjectTransform::default();
    if let Some(t) = numbers {
        let v: Vec<f32> = t.split(',').map(|x| x.trim().parse().unwrap()).collect();
        if !matches!(v.len(), 3 | 6 | 7) || v.iter().any(|x| !x.is_finite()) {
            return Err(format!(
                "'{s}': the transform after ':' is TX,TY,TZ[,RX,RY,RZ[,S]] (3, 6 or 7 finite \
                 numbers; rotations in degrees), got {} numbers",
                v.len()
            ));
        }
        transform.translation = Vec3::new(v[0], v[1], v[2]);
        if v.len() >= 6 {
            let r = |d: f32| d.to_radians();
            transform.rotation = Quat::from_rotation_z(r(v[5]))
                * Quat::from_rotation_y(r(v[4]))
                * Quat::from_rotation_x(r(v[3]));
        }
        if v.len() == 7 {
            transform.scale = v[6];
        }
        transform.validate().map_err(|e| format!("'{s}': {e}"))?;
    }
    Ok(ObjectArg {
        path: PathBuf::from(path),
        transform,
    })
}

/// The scenes of `objects`, loaded, with `scene` (when given) first as an object of its own
/// at the identity.
pub fn load(
    scene: Option<&PathBuf>,
    objects: &[ObjectArg],
) -> Result<Vec<(Scene, ObjectTransform)>> {
    let mut out = Vec::new();
    if let Some(path) = scene {
        out.push((super::load::load_scene(path)?, ObjectTransform::default()));
    }
    for o in objects {
        out.push((super::load::load_scene(&o.path)?, o.transform));
    }
    if out.iter().all(|(s, _)| s.is_empty()) {
        return Err(Error::InvalidInput("the objects hold no Gaussians".into()));
    }
    Ok(out)
}

/// The loaded objects' scenes on the device of `renderer`, in order.
pub fn upload(
    renderer: &rara::Renderer,
    loaded: &[(Scene, ObjectTransform)],
) -> Result<Vec<rara::GpuScene>> {
    loaded.iter().map(|(s, _)| renderer.upload(s)).collect()
}

/// The objects to draw: each uploaded scene with its transform.
pub fn scene_objects<'a>(
    uploaded: &'a [rara::GpuScene],
    loaded: &[(Scene, ObjectTransform)],
) -> Vec<rara::SceneObject<'a>> {
    uploaded
        .iter()
        .zip(loaded)
        .map(|(scene, (_, transform))| rara::SceneObject::new(scene, *transform))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn object_arguments_parse() {
        let o = parse_object("a.ply").unwrap();
        assert_eq!(o.path, PathBuf::from("a.ply"));
        assert_eq!(o.transform, ObjectTransform::default());
        let o = parse_object("dir/b.spz:1,2,3").unwrap();
        assert_eq!(o.path, PathBuf::from("dir/b.spz"));
        assert_eq!(o.transform.translation, Vec3::new(1.0, 2.0, 3.0));
        let o = parse_object("c.ply:0,0,0,0,90,0,2").unwrap();
        assert!((o.transform.rotation * Vec3::X - Vec3::NEG_Z).length() < 1e-6);
        assert_eq!(o.transform.scale, 2.0);
        assert!(parse_object("c.ply:1,2").is_err());
        assert!(parse_object("c.ply:0,0,0,0,0,0,-1").is_err());
    }
}
