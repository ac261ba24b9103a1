//! Nodes and animation: the node trees placed as objects (with skins and
//! morph weights), punctual lights, and the animation channels played.

use super::*;

impl Loader<'_> {
    #[allow(clippy::too_many_arguments)]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn node(
        &mut self,
        index: usize,
        (parent, parent_slot): (Mat4, Option<usize>),
        depth: usize,
        visited: &mut HashSet<usize>,
        scene: &mut Scene,
        materials: &[u32],
        default_material: u32,
    ) -> Result<()> {
        let root = self.root;
        let node = root
            .nodes
            .get(index)
            .ok_or_else(|| self.err(format!("node index {index} out of range")))?;
        if depth > MAX_DEPTH {
            return Err(self.err(format!("node hierarchy deeper than {MAX_DEPTH}")));
        }
        // glTF nodes form disjoint trees: a node reached twice is shared or
        // its own ancestor (visiting it again could repeat work without end).
        if !visited.insert(index) {
            return Err(self.err(format!(
                "node {index} is reached twice (nodes must form trees; a cycle or a shared child)"
            )));
        }
        let rest = match node.matrix {
            Some(m) => Mat4::from_cols_array(&m),
            None => Mat4::from_scale_rotation_translation(
                node.scale.map(Vec3::from).unwrap_or(Vec3::ONE),
                node.rotation
                    .map(|q| Quat::from_array(q.0).normalize())
                    .unwrap_or(Quat::IDENTITY),
                node.translation.map(Vec3::from).unwrap_or(Vec3::ZERO),
            ),
        };
        // Animated parts replace the rest pose's (animated nodes have no
        // matrix in valid files; one is decomposed).
        let local = crate::scene::animation::local_transform(rest, self.poses.get(&index));
        let world = parent * local;
        let slot = self.pose_nodes.len();
        self.pose_nodes.push(PoseNode {
            node: index,
            parent: parent_slot,
            rest,
        });
        if !world.is_finite() {
            return Err(self.err(format!("node {index} has a non-finite transform")));
        }
        self.worlds.insert(index, world);
        match (node.mesh, node.skin) {
            // Skinned: posed by its joints once their transforms are known.
            (Some(mesh), Some(skin)) => self.skinned.push((index, mesh.value(), skin.value())),
            (Some(mesh), None) => {
                let weights = self.morph_weights(node, mesh.value())?;
                let key = (mesh.value(), weights.iter().map(|w| w.to_bits()).collect());
                let meshes = match self.meshes.get(&key) {
                    Some(m) => m.clone(),
                    None => {
                        let m = self.mesh(mesh.value(), &weights, None, scene, materials, default_material)?;
                        self.meshes.insert(key, m.clone());
                        m
                    }
                };
                for mesh in meshes {
                    self.add_object(scene, crate::scene::Object::at_node(mesh, world, index), index)?;
                }
            }
            _ => {}
        }
        if let Some(cam) = node.camera {
            self.camera(cam.value(), world, scene)?;
        }
        if let Some(l) = node
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
        {
            scene.lights.push(self.light(l.light.value(), world)?);
        }
        for child in node.children.iter().flatten() {
            self.node(
                child.value(),
                (world, Some(slot)),
                depth + 1,
                visited,
                scene,
                materials,
                default_material,
            )?;
        }
        Ok(())
    }

    /// Adds camera `index`, placed by its node's `world` transform (one
    /// that is not a valid perspective camera is skipped with a warning).
    pub(super) fn camera(&self, index: usize, world: Mat4, scene: &mut Scene) -> Result<()> {
        let c = self
            .root
            .cameras
            .get(index)
            .ok_or_else(|| self.err(format!("camera index {index} out of range")))?;
        match &c.perspective {
            Some(p) if p.yfov > 0.0 && p.yfov < std::f32::consts::PI => {
                let (_, rot, pos) = world.to_scale_rotation_translation();
                scene.cameras.push(Camera {
                    position: pos,
                    forward: (rot * -Vec3::Z).normalize(),
                    up: (rot * Vec3::Y).normalize(),
                    yfov: p.yfov,
                    jitter: glam::Vec2::ZERO,
                });
            }
            _ => log::warn!(
                "{}: camera {} is not a valid perspective camera; skipped",
                self.name,
                index
            ),
        }
        Ok(())
    }

    /// Adds an object drawn by node `index`, within the world's triangle
    /// and memory budgets.
    pub(super) fn add_object(&self, scene: &mut Scene, object: crate::scene::Object, index: usize) -> Result<()> {
        let added = scene.meshes()[object.mesh].triangle_count();
        if scene.triangle_count() + added > MAX_TRIANGLES {
            return Err(self.err(format!(
                "more than {MAX_TRIANGLES} triangles in the world (node {index} draws mesh {} again)",
                object.mesh
            )));
        }
        self.check_budget(std::mem::size_of::<crate::scene::Object>() as u64)?;
        scene
            .add_object(object)
            .map(|_| ())
            .map_err(|e| self.err(format!("node {index}: {e}")))
    }

    /// The morph-target weights node `node` draws mesh `mesh` with: its
    /// own, else the mesh's defaults (glTF 2.0, 3.7.2.2); none without.
    pub(super) fn morph_weights(&self, node: &json::Node, mesh: usize) -> Result<Vec<f32>> {
        let defaults = self.root.meshes.get(mesh).and_then(|m| m.weights.as_ref());
        let weights = node.weights.as_ref().or(defaults).cloned().unwrap_or_default();
        if weights.iter().any(|w| !w.is_finite()) {
            return Err(self.err(format!("mesh {mesh}: a morph-target weight is not finite")));
        }
        Ok(weights)
    }

    /// Node `index`'s skinned mesh, posed by its skin's joints: each
    /// joint's world transform (animated, at the loaded time) times its
    /// inverse bind matrix. The node's own transform does not apply
    /// (glTF 2.0, 3.7.3.3). The object does not follow later posing
    /// (animation playback moves nodes' objects, not skins' vertices).
    pub(super) fn skinned_mesh(
        &mut self,
        index: usize,
        mesh: usize,
        skin: usize,
        scene: &mut Scene,
        materials: &[u32],
        default_material: u32,
    ) -> Result<()> {
        let root = self.root;
        let s = root
            .skins
            .get(skin)
            .ok_or_else(|| self.err(format!("node {index}: skin index {skin} out of range")))?;
        let inverse_binds: Vec<Mat4> = match s.inverse_bind_matrices {
            Some(a) => self
                .read_floats(a.value(), 16)?
                .chunks_exact(16)
                .map(Mat4::from_cols_slice)
                .collect(),
            None => vec![Mat4::IDENTITY; s.joints.len()],
        };
        if inverse_binds.len() < s.joints.len() {
            return Err(self.err(format!(
                "skin {skin}: {} inverse bind matrices for {} joints",
                inverse_binds.len(),
                s.joints.len()
            )));
        }
        let mut joints = Vec::with_capacity(s.joints.len());
        for (j, ibm) in s.joints.iter().zip(&inverse_binds) {
            let Some(world) = self.worlds.get(&j.value()) else {
                return Err(self.err(format!(
                    "skin {skin}: joint node {} is not in the scene drawn",
                    j.value()
                )));
            };
            joints.push(*world * *ibm);
        }
        let weights = self.morph_weights(&root.nodes[index], mesh)?;
        let made = self.mesh(mesh, &weights, Some((&joints, self.worlds[&index])), scene, materials, default_material)?;
        for m in made {
            self.add_object(scene, crate::scene::Object::new(m, Mat4::IDENTITY), index)?;
        }
        Ok(())
    }

    pub(super) fn light(&self, index: usize, world: Mat4) -> Result<Light> {
        use json::extensions::scene::khr_lights_punctual::Type as T;
        let lights = self
            .root
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
            .map(|k| &k.lights[..])
            .unwrap_or(&[]);
        let l = lights
            .get(index)
            .ok_or_else(|| self.err(format!("light index {index} out of range")))?;
        let intensity = Vec3::from(l.color) * l.intensity;
        if !intensity.is_finite() || intensity.min_element() < 0.0 {
            return Err(self.err(format!(
                "light {index} has a negative or non-finite intensity"
            )));
        }
        let position = world.transform_point3(Vec3::ZERO);
        let direction = world.transform_vector3(-Vec3::Z).normalize_or_zero();
        if direction == Vec3::ZERO {
            return Err(self.err(format!("light {index} has a degenerate orientation")));
        }
        let kind = match checked(&l.type_) {
            Some(T::Point) => LightKind::Point,
            Some(T::Directional) => LightKind::Directional,
            Some(T::Spot) => {
                let s = l
                    .spot
                    .as_ref()
                    .ok_or_else(|| self.err(format!("spot light {index} has no cone")))?;
                let (inner, outer) = (s.inner_cone_angle, s.outer_cone_angle);
                if !(0.0..std::f32::consts::FRAC_PI_2).contains(&outer)
                    || !(0.0..=outer).contains(&inner)
                {
                    return Err(self.err(format!("spot light {index} has invalid cone angles")));
                }
                LightKind::Spot {
                    inner_cone: inner,
                    outer_cone: outer,
                }
            }
            None => return Err(self.err(format!("light {index} has an unknown type"))),
        };
        Ok(Light {
            kind,
            position,
            direction,
            intensity,
        })
    }

    /// One warning naming what moves a glTF scene that ssbc does not play.
    /// Nodes are drawn at their rest transforms (or the first animation's
    /// at the time given), meshes with their morph targets at their
    /// weights, skinned meshes posed by their joints at load; not played:
    /// other animations, animated morph weights, and skins during playback
    /// (posing later moves nodes' objects, not skinned vertices).
    pub(super) fn warn_not_played(&self) {
        let r = &self.root;
        let animated = !r.animations.is_empty();
        let skinned = r.nodes.iter().filter(|n| n.skin.is_some()).count();
        let weight_channels = r
            .animations
            .iter()
            .flat_map(|a| &a.channels)
            .filter(|c| {
                checked(&c.target.path) == Some(json::animation::Property::MorphTargetWeights)
            })
            .count();
        // With a time, the first animation plays.
        let played = usize::from(self.time.is_some());
        let parts: Vec<String> = [
            (r.animations.len().saturating_sub(played), "animation", "animations"),
            (weight_channels, "morph-weight channel", "morph-weight channels"),
            (
                if animated { skinned } else { 0 },
                "skinned node (posed once, at load)",
                "skinned nodes (posed once, at load)",
            ),
        ]
        .into_iter()
        .filter(|(n, ..)| *n > 0)
        .map(|(n, one, many)| format!("{n} {}", if n == 1 { one } else { many }))
        .collect();
        if !parts.is_empty() {
            log::warn!("{}: not played: {}", self.name, parts.join(", "));
        }
    }

    /// The first animation's last keyframe time, from its input accessors'
    /// declared maxima (reading no data: a file whose animation is broken
    /// still loads at rest).
    pub(super) fn animation_end(&self) -> Option<f32> {
        let animation = self.root.animations.first()?;
        animation
            .samplers
            .iter()
            .filter_map(|s| self.root.accessors.get(s.input.value())?.max.as_ref())
            .filter_map(|max| max.as_array()?.first()?.as_f64())
            .map(|t| t as f32)
            .filter(|t| t.is_finite() && *t >= 0.0)
            .reduce(f32::max)
    }

    /// The first animation's channels (none without one). Morph-target
    /// weights are not played (warn_not_played).
    pub(super) fn animation_channels(&mut self) -> Result<Vec<Channel>> {
        let mut channels = Vec::new();
        let root = self.root;
        let Some(animation) = root.animations.first() else {
            if self.time.is_some() {
                log::warn!("{}: a time was given but the file has no animation", self.name);
            }
            return Ok(channels);
        };
        if root.animations.len() > 1 && self.time.is_some() {
            log::warn!(
                "{}: playing animation 0 ('{}') of {}",
                self.name,
                animation.name.as_deref().unwrap_or(""),
                root.animations.len()
            );
        }
        for (c, channel) in animation.channels.iter().enumerate() {
            let what = |m: String| format!("animation 0, channel {c}: {m}");
            let node = channel.target.node.value();
            if node >= root.nodes.len() {
                return Err(self.err(what(format!("targets node {node}, which does not exist"))));
            }
            use json::animation::Property as P;
            let path = match checked(&channel.target.path) {
                Some(P::Translation) => AnimPath::Translation,
                Some(P::Rotation) => AnimPath::Rotation,
                Some(P::Scale) => AnimPath::Scale,
                Some(P::MorphTargetWeights) => continue,
                None => return Err(self.err(what("an unknown target path".into()))),
            };
            let k = channel.sampler.value();
            let s = animation
                .samplers
                .get(k)
                .ok_or_else(|| self.err(what(format!("sampler {k} does not exist"))))?;
            use json::animation::Interpolation as I;
            let interpolation = match checked(&s.interpolation) {
                Some(I::Linear) => Interpolation::Linear,
                Some(I::Step) => Interpolation::Step,
                Some(I::CubicSpline) => Interpolation::CubicSpline,
                None => return Err(self.err(what("an unknown interpolation".into()))),
            };
            let sampler = Sampler {
                times: self.read_floats(s.input.value(), 1)?,
                values: self.read_floats(s.output.value(), path.components())?,
                interpolation,
            };
            sampler
                .check(path.components())
                .map_err(|m| self.err(what(format!("sampler {k}: {m}"))))?;
            channels.push(Channel {
                node,
                path,
                sampler,
            });
        }
        Ok(channels)
    }
}
