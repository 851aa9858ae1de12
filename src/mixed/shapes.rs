//! Meshes the crate makes itself, for tests and the examples in `examples/scenes/` (no
//! third-party data): a quad, a box and a UV sphere, as triangles or as OBJ text.

use glam::Vec3;

use super::triangles::Triangle;

/// A mesh as vertices (with normals) and triangles.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Shape {
    /// Positions.
    pub positions: Vec<Vec3>,
    /// Unit normals, one per position.
    pub normals: Vec<Vec3>,
    /// Triangles, counter-clockwise seen from outside.
    pub faces: Vec<[u32; 3]>,
}

impl Shape {
    /// The unit square `[-1, 1]^2` in the plane z = 0, facing +z.
    pub fn quad() -> Shape {
        Shape {
            positions: vec![
                Vec3::new(-1.0, -1.0, 0.0),
                Vec3::new(1.0, -1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(-1.0, 1.0, 0.0),
            ],
            normals: vec![Vec3::Z; 4],
            faces: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    /// The cube `[-1, 1]^3`, four vertices per face so that each face keeps its own normal.
    pub fn cube() -> Shape {
        let mut s = Shape::default();
        for axis in 0..3 {
            for sign in [-1.0f32, 1.0] {
                let mut n = Vec3::ZERO;
                n[axis] = sign;
                // Two in-plane axes with u x v = n.
                let mut u = Vec3::ZERO;
                u[(axis + 1) % 3] = 1.0;
                let mut v = Vec3::ZERO;
                v[(axis + 2) % 3] = sign;
                let base = s.positions.len() as u32;
                for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                    s.positions.push(n + a * u + b * v);
                    s.normals.push(n);
                }
                s.faces.push([base, base + 1, base + 2]);
                s.faces.push([base, base + 2, base + 3]);
            }
        }
        s
    }

    /// The unit sphere with `rings` latitude bands and `segments` longitudes, smooth normals.
    pub fn sphere(rings: u32, segments: u32) -> Shape {
        let mut s = Shape::default();
        for r in 0..=rings {
            let theta = std::f32::consts::PI * r as f32 / rings as f32;
            for k in 0..=segments {
                let phi = 2.0 * std::f32::consts::PI * k as f32 / segments as f32;
                let p = Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                );
                s.positions.push(p);
                s.normals.push(p);
            }
        }
        let row = segments + 1;
        for r in 0..rings {
            for k in 0..segments {
                let (a, b) = (r * row + k, (r + 1) * row + k);
                if r > 0 {
                    s.faces.push([a, a + 1, b]);
                }
                if r + 1 < rings {
                    s.faces.push([a + 1, b + 1, b]);
                }
            }
        }
        s
    }

    /// The triangles, each point mapped by `f` and each normal by `fn_`, with `material`.
    pub fn triangles(
        &self,
        f: impl Fn(Vec3) -> Vec3,
        fn_: impl Fn(Vec3) -> Vec3,
        material: u32,
    ) -> Vec<Triangle> {
        self.faces
            .iter()
            .map(|t| {
                let idx = t.map(|i| i as usize);
                Triangle {
                    v: idx.map(|i| f(self.positions[i])),
                    n: idx.map(|i| fn_(self.normals[i]).normalize()),
                    uv: [glam::Vec2::ZERO; 3],
                    material,
                }
            })
            .collect()
    }

    /// The mesh as an OBJ file (`v`, `vn`, `f v//vn`), with a comment line on top.
    pub fn to_obj(&self, comment: &str) -> String {
        let mut out = format!("# {comment}\n");
        for p in &self.positions {
            out += &format!("v {} {} {}\n", p.x, p.y, p.z);
        }
        for n in &self.normals {
            out += &format!("vn {} {} {}\n", n.x, n.y, n.z);
        }
        for f in &self.faces {
            let [a, b, c] = f.map(|i| i + 1);
            out += &format!("f {a}//{a} {b}//{b} {c}//{c}\n");
        }
        out
    }
}
