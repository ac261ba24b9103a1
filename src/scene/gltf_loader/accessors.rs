//! Buffers, views and accessors, read with bounds checks (sparse
//! accessors substituted), and URIs resolved inside the scene's folder.

use super::*;

impl Loader<'_> {
    /// The bytes of buffer `index` (GLB blob, data URI, or file in the scene folder).
    pub(super) fn buffer(&mut self, index: usize) -> Result<&[u8]> {
        if self.buffers.get(index).is_none() {
            return Err(self.err(format!("buffer index {index} out of range")));
        }
        if self.buffers[index].is_none() {
            let b = &self.root.buffers[index];
            let data = match &b.uri {
                None => self.blob.clone().ok_or_else(|| {
                    self.err(format!(
                        "buffer {index} has no URI and there is no GLB binary chunk"
                    ))
                })?,
                Some(uri) => self.read_uri(uri)?,
            };
            if (data.len() as u64) < b.byte_length.0 {
                return Err(self.err(format!(
                    "buffer {index} is {} bytes, shorter than its byteLength {}",
                    data.len(),
                    b.byte_length.0
                )));
            }
            self.buffers[index] = Some(data);
        }
        Ok(self.buffers[index].as_deref().unwrap())
    }

    /// Reads a data URI, or a relative file path inside the scene's folder.
    pub(super) fn read_uri(&self, uri: &str) -> Result<Vec<u8>> {
        if let Some(rest) = uri.strip_prefix("data:") {
            let (_, payload) = rest
                .split_once(";base64,")
                .ok_or_else(|| self.err("only base64 data URIs are supported"))?;
            if payload.len() as u64 > MAX_BYTES * 4 / 3 {
                return Err(self.err("data URI too large"));
            }
            return base64::engine::general_purpose::STANDARD
                .decode(payload)
                .map_err(|e| self.err(format!("bad base64 data URI: {e}")));
        }
        if uri.contains(':') {
            return Err(self.err(format!(
                "refusing URI '{uri}': only relative paths and data URIs are read"
            )));
        }
        let decoded = percent_encoding::percent_decode_str(uri)
            .decode_utf8()
            .map_err(|_| self.err(format!("URI '{uri}' is not valid percent-encoded UTF-8")))?;
        let relative = PathBuf::from(decoded.as_ref());
        if relative.is_absolute() || relative.has_root() {
            return Err(self.err(format!(
                "refusing absolute path '{uri}' (outside the scene's folder)"
            )));
        }
        // Lexical check first (the file need not exist to be refused), then
        // the canonical path (catches symlinks out of the folder).
        let mut depth = 0i32;
        for c in relative.components() {
            match c {
                std::path::Component::ParentDir => depth -= 1,
                std::path::Component::Normal(_) => depth += 1,
                _ => {}
            }
            if depth < 0 {
                return Err(self.err(format!(
                    "refusing '{uri}': it points outside the scene's folder"
                )));
            }
        }
        let path = self.base.join(&relative);
        let resolved = path
            .canonicalize()
            .map_err(|e| self.err(format!("cannot open '{uri}': {e}")))?;
        if !resolved.starts_with(self.base) {
            return Err(self.err(format!(
                "refusing '{uri}': it points outside the scene's folder"
            )));
        }
        let len = std::fs::metadata(&resolved)
            .map_err(|e| Error::io(&resolved, e))?
            .len();
        if len > MAX_BYTES {
            return Err(self.err(format!("'{uri}' is larger than {MAX_BYTES} bytes")));
        }
        let bytes = std::fs::read(&resolved).map_err(|e| Error::io(&resolved, e))?;
        self.input_bytes
            .set(self.input_bytes.get().saturating_add(bytes.len() as u64));
        Ok(bytes)
    }

    /// The byte range of buffer view `index` (checked), and its stride.
    pub(super) fn view(&mut self, index: usize) -> Result<(&[u8], Option<usize>)> {
        let v = self
            .root
            .buffer_views
            .get(index)
            .ok_or_else(|| self.err(format!("bufferView index {index} out of range")))?;
        let (offset, length) = (v.byte_offset.map(|o| o.0).unwrap_or(0), v.byte_length.0);
        let stride = v.byte_stride.map(|s| s.0);
        let buffer_index = v.buffer.value();
        let name = self.name;
        let data = self.buffer(buffer_index)?;
        let end = offset
            .checked_add(length)
            .filter(|&e| e <= data.len() as u64)
            .ok_or_else(|| {
                Error::scene(
                    name,
                    format!("bufferView {index} runs past the end of buffer {buffer_index}"),
                )
            })?;
        Ok((&data[offset as usize..end as usize], stride))
    }

    /// Reads accessor `index` as elements of `components` numbers each: its
    /// component type and the elements' bytes, packed without stride.
    pub(super) fn accessor_elements(
        &mut self,
        index: usize,
        components: usize,
    ) -> Result<(ComponentType, Vec<u8>)> {
        let a = self
            .root
            .accessors
            .get(index)
            .ok_or_else(|| self.err(format!("accessor index {index} out of range")))?;
        let ty = checked(&a.type_)
            .ok_or_else(|| self.err(format!("accessor {index} has an invalid type")))?;
        let expected = match ty {
            Type::Scalar => 1,
            Type::Vec2 => 2,
            Type::Vec3 => 3,
            Type::Vec4 => 4,
            // Inverse bind matrices (floats: no column padding).
            Type::Mat4 => 16,
            _ => 0,
        };
        if expected != components {
            return Err(self.err(format!(
                "accessor {index} has type {ty:?}, expected {components} components"
            )));
        }
        let ct = checked(&a.component_type)
            .ok_or_else(|| self.err(format!("accessor {index} has an invalid component type")))?
            .0;
        let count = a.count.0 as usize;
        if count == 0 || count > 3 * MAX_TRIANGLES {
            return Err(self.err(format!(
                "accessor {index} has an unreasonable count {count}"
            )));
        }
        let elem = ct.size() * components;
        // Zeros, or a bufferView's elements, then a sparse substitution.
        let mut packed = match a.buffer_view {
            None => {
                // Nothing is read, so the input does not bound it: the
                // scene's whole budget does.
                if (count * elem) as u64 > self.budget() {
                    return Err(self.err(format!(
                        "accessor {index}: {count} elements without a bufferView exceed the scene's budget"
                    )));
                }
                vec![0u8; count * elem]
            }
            Some(view) => {
                let offset = a.byte_offset.map(|o| o.0 as usize).unwrap_or(0);
                let (bytes, stride) = self.view(view.value())?;
                let stride = stride.unwrap_or(elem);
                if stride < elem {
                    return Err(Error::scene(
                        self.name,
                        format!("accessor {index}: byteStride {stride} smaller than an element"),
                    ));
                }
                let needed = stride
                    .checked_mul(count - 1)
                    .and_then(|n| n.checked_add(offset))
                    .and_then(|n| n.checked_add(elem));
                if needed.is_none_or(|n| n > bytes.len()) {
                    return Err(Error::scene(
                        self.name,
                        format!("accessor {index} runs past the end of its bufferView"),
                    ));
                }
                let mut packed = Vec::with_capacity(count * elem);
                for i in 0..count {
                    packed.extend_from_slice(&bytes[offset + i * stride..offset + i * stride + elem]);
                }
                packed
            }
        };
        if let Some(sparse) = &a.sparse {
            self.substitute_sparse(index, sparse, elem, &mut packed)?;
        }
        Ok((ct, packed))
    }

    /// Overwrites the elements of accessor `index` (`packed`, `elem` bytes
    /// each) that its sparse part lists.
    pub(super) fn substitute_sparse(
        &mut self,
        index: usize,
        sparse: &json::accessor::sparse::Sparse,
        elem: usize,
        packed: &mut [u8],
    ) -> Result<()> {
        let count = packed.len() / elem;
        let n = sparse.count.0 as usize;
        if n == 0 || n > count {
            return Err(self.err(format!(
                "accessor {index}: sparse count {n} is not in 1..={count}"
            )));
        }
        let ict = checked(&sparse.indices.component_type)
            .ok_or_else(|| self.err(format!("accessor {index}: invalid sparse index type")))?
            .0;
        let ranges = [
            (&sparse.indices.buffer_view, sparse.indices.byte_offset.0, ict.size()),
            (&sparse.values.buffer_view, sparse.values.byte_offset.0, elem),
        ];
        let name = self.name;
        let mut read = Vec::with_capacity(2);
        for (view, offset, size) in ranges {
            let (bytes, _) = self.view(view.value())?;
            let range = (offset as usize)..(offset as usize).saturating_add(n * size);
            let chunk = bytes.get(range).ok_or_else(|| {
                Error::scene(
                    name,
                    format!("accessor {index}: sparse data runs past the end of its bufferView"),
                )
            })?;
            read.push(chunk.to_vec());
        }
        for (k, value) in read[1].chunks_exact(elem).enumerate() {
            let at = &read[0][k * ict.size()..(k + 1) * ict.size()];
            let i = match ict {
                ComponentType::U8 => at[0] as usize,
                ComponentType::U16 => u16::from_le_bytes([at[0], at[1]]) as usize,
                _ => u32::from_le_bytes([at[0], at[1], at[2], at[3]]) as usize,
            };
            let target = packed.get_mut(i * elem..(i + 1) * elem).ok_or_else(|| {
                Error::scene(
                    self.name,
                    format!("accessor {index}: sparse index {i} out of range ({count} elements)"),
                )
            })?;
            target.copy_from_slice(value);
        }
        Ok(())
    }

    /// Attribute data as floats, flattened: float, or integers (signed or
    /// unsigned, 8 or 16 bits) normalized or not, as the core specification
    /// and `KHR_mesh_quantization` allow them (a node's transform then
    /// usually scales quantized positions back).
    pub(super) fn read_floats(&mut self, index: usize, components: usize) -> Result<Vec<f32>> {
        let normalized = self
            .root
            .accessors
            .get(index)
            .map(|a| a.normalized)
            .unwrap_or(false);
        let (ct, packed) = self.accessor_elements(index, components)?;
        let mut out = Vec::with_capacity(packed.len() / ct.size());
        for c in packed.chunks_exact(ct.size()) {
            // Signed normalized values map -max and -max - 1 both to -1.
            let scaled = |v: f32, max: f32| if normalized { (v / max).max(-1.0) } else { v };
            let v = match ct {
                ComponentType::F32 => f32::from_le_bytes([c[0], c[1], c[2], c[3]]),
                ComponentType::U8 => scaled(c[0] as f32, 255.0),
                ComponentType::I8 => scaled(c[0] as i8 as f32, 127.0),
                ComponentType::U16 => scaled(u16::from_le_bytes([c[0], c[1]]) as f32, 65535.0),
                ComponentType::I16 => scaled(i16::from_le_bytes([c[0], c[1]]) as f32, 32767.0),
                ComponentType::U32 => {
                    return Err(self.err(format!(
                        "accessor {index}: component type {ct:?} not supported here"
                    )))
                }
            };
            if !v.is_finite() {
                return Err(self.err(format!("accessor {index} holds a non-finite number")));
            }
            out.push(v);
        }
        Ok(out)
    }

    /// COLOR_0 of mesh `mesh` primitive `pi` (accessor `index`): RGB or
    /// RGBA, float or normalized integers, as RGBA. Floats outside [0, 1]
    /// are clamped, with a warning.
    pub(super) fn read_colors(&mut self, index: usize, mesh: usize, pi: usize) -> Result<Vec<Vec4>> {
        let components = match self.root.accessors.get(index).map(|a| checked(&a.type_)) {
            Some(Some(Type::Vec3)) => 3,
            Some(Some(Type::Vec4)) => 4,
            Some(_) => {
                return Err(self.err(format!(
                    "mesh {mesh} primitive {pi}: COLOR_0 must be VEC3 or VEC4"
                )))
            }
            None => return Err(self.err(format!("accessor index {index} out of range"))),
        };
        let raw = self.read_floats(index, components)?;
        let colors: Vec<Vec4> = raw
            .chunks_exact(components)
            .map(|c| Vec4::new(c[0], c[1], c[2], c.get(3).copied().unwrap_or(1.0)))
            .collect();
        if colors.iter().any(|c| c.min_element() < 0.0 || c.max_element() > 1.0) {
            log::warn!(
                "{}: mesh {mesh} primitive {pi}: COLOR_0 values outside [0, 1] are clamped",
                self.name
            );
        }
        Ok(colors
            .into_iter()
            .map(|c| c.clamp(Vec4::ZERO, Vec4::ONE))
            .collect())
    }

    /// Index data (u8, u16 or u32).
    pub(super) fn read_indices(&mut self, index: usize) -> Result<Vec<u32>> {
        let (ct, packed) = self.accessor_elements(index, 1)?;
        packed
            .chunks_exact(ct.size())
            .map(|e| match ct {
                ComponentType::U8 => Ok(e[0] as u32),
                ComponentType::U16 => Ok(u16::from_le_bytes([e[0], e[1]]) as u32),
                ComponentType::U32 => Ok(u32::from_le_bytes([e[0], e[1], e[2], e[3]])),
                _ => Err(self.err(format!(
                    "accessor {index}: indices must be unsigned integers"
                ))),
            })
            .collect()
    }
}
