//! Objects as a scene takes them in: adding, moving, hiding and removing
//! the objects that draw its meshes, and the instances they make.

use super::*;

impl Scene {
    /// The objects.
    pub fn objects(&self) -> &[Object] {
        &self.objects
    }

    /// Adds `object` and returns its index; its mesh and material must
    /// exist, its transform be finite and invertible, and the world stay
    /// within [`MAX_TRIANGLES`].
    pub fn add_object(&mut self, object: Object) -> Result<usize> {
        self.check_object(&object)?;
        let added = self.meshes[object.mesh].triangle_count();
        if object.visible && self.triangle_count() + added > MAX_TRIANGLES {
            return Err(Error::scene(
                &self.name,
                format!("more than {MAX_TRIANGLES} triangles in the world"),
            ));
        }
        let index = self.objects.len();
        // The numbering grows by the new object (no renumbering: a file of
        // a million nodes loads in linear time).
        if let Some(instances) = self.instances.get_mut() {
            instances.push(index, &object, &self.meshes[object.mesh]);
        }
        self.objects.push(object);
        Ok(index)
    }

    /// Moves object `index` to `transform` (object to world).
    pub fn set_transform(&mut self, index: usize, transform: Mat4) -> Result<()> {
        check_transform(&transform)?;
        self.object_mut(index)?.transform = transform;
        Ok(())
    }

    /// Shows or hides object `index`.
    pub fn set_visible(&mut self, index: usize, visible: bool) -> Result<()> {
        let mesh = self.object(index)?.mesh;
        let added = self.meshes[mesh].triangle_count();
        if visible && !self.objects[index].visible && self.triangle_count() + added > MAX_TRIANGLES
        {
            return Err(Error::scene(
                &self.name,
                format!("more than {MAX_TRIANGLES} triangles in the world"),
            ));
        }
        self.object_mut(index)?.visible = visible;
        Ok(())
    }

    /// Draws object `index` with `material` instead of its mesh's (None:
    /// the mesh's own).
    pub fn set_object_material(&mut self, index: usize, material: Option<u32>) -> Result<()> {
        if let Some(m) = material.filter(|&m| m as usize >= self.materials.len()) {
            return Err(Error::InvalidParameter(format!(
                "material {m} does not exist ({} materials)",
                self.materials.len()
            )));
        }
        self.object_mut(index)?.material = material;
        Ok(())
    }

    /// Removes object `index` (later objects move down by one).
    pub fn remove_object(&mut self, index: usize) -> Result<Object> {
        self.object(index)?;
        self.instances = Default::default();
        Ok(self.objects.remove(index))
    }

    /// Object `index`, or an error naming the range.
    pub fn object(&self, index: usize) -> Result<&Object> {
        self.objects
            .get(index)
            .ok_or_else(|| out_of_range("object", index, self.objects.len()))
    }

    fn object_mut(&mut self, index: usize) -> Result<&mut Object> {
        self.instances = Default::default();
        let count = self.objects.len();
        self.objects
            .get_mut(index)
            .ok_or_else(|| out_of_range("object", index, count))
    }

    pub(super) fn check_object(&self, o: &Object) -> Result<()> {
        if o.mesh >= self.meshes.len() {
            return Err(out_of_range("mesh", o.mesh, self.meshes.len()));
        }
        if let Some(m) = o.material.filter(|&m| m as usize >= self.materials.len()) {
            return Err(out_of_range("material", m as usize, self.materials.len()));
        }
        check_transform(&o.transform)
    }

    /// The visible objects numbered by triangle: how world triangles map to
    /// meshes (kept until meshes or objects change).
    pub fn instances(&self) -> &Instances {
        self.instances
            .get_or_init(|| Instances::new(&self.meshes, &self.objects))
    }
}
