//! A glTF/GLB file's skin as rig joints ([`read_gltf_joints`]), read with the `gltf` crate (the
//! JSON only: no buffers or images are decoded; the rest pose is the nodes' TRS, which in the
//! mannequins is the bind pose).
//!
//! - **Which skin**: the one with the most joints (a file with a character and a prop keeps the
//!   character's).
//! - **Joints**: the skin's joints in parents-first order, each with its node name (an unnamed
//!   node is `node{index}`), its parent the nearest ancestor node that is also a skin joint, and
//!   its rest local rotation and translation relative to that parent (nodes in between, which
//!   are not joints, are folded in). A skin joint's scale is taken as 1 (the rotations are what
//!   the engines drive).
//! - **Roots**: one skin root keeps the transforms of the nodes above it (e.g. Blender's
//!   `Armature`) folded into its rest transform, so its rest world pose is right; a skin with
//!   several roots gets a synthetic root joint (`__rig_root`, identity at the origin) above them.
use std::path::Path;

use glam::{Mat4, Quat, Vec3};

use super::{RigJoint, RigTargetError};

/// The largest glTF/GLB file read (bytes): a game character with textures is well under it.
pub const MAX_GLTF_BYTES: u64 = 256 << 20;

/// The joints of the largest skin of a glTF (`.gltf`) or GLB (`.glb`) file (see the module docs).
///
/// # Errors
/// The file cannot be read, is not glTF, or has no skin with at least two joints.
pub fn read_gltf_joints(path: &Path) -> Result<Vec<RigJoint>, RigTargetError> {
    let fail = |problem: String| RigTargetError::File {
        path: path.to_path_buf(),
        problem,
    };
    let size = std::fs::metadata(path)
        .map_err(|e| fail(e.to_string()))?
        .len();
    if size > MAX_GLTF_BYTES {
        return Err(fail(format!(
            "{size} bytes, more than the {MAX_GLTF_BYTES} a glTF character is read from"
        )));
    }
    let bytes = std::fs::read(path).map_err(|e| fail(e.to_string()))?;
    let gltf = gltf::Gltf::from_slice(&bytes).map_err(|e| fail(format!("not glTF: {e}")))?;
    joints_of(&gltf.document).map_err(fail)
}

/// The joints of a parsed document's largest skin.
fn joints_of(doc: &gltf::Document) -> Result<Vec<RigJoint>, String> {
    let skin = doc
        .skins()
        .max_by_key(|s| s.joints().count())
        .ok_or("no skin: the file has no rigged mesh")?;
    let nodes: Vec<gltf::Node<'_>> = doc.nodes().collect();
    let n = nodes.len();
    let mut parent = vec![None; n];
    for node in &nodes {
        for child in node.children() {
            if parent[child.index()].is_some() {
                return Err(format!(
                    "node {} has two parents: not a tree",
                    child.index()
                ));
            }
            parent[child.index()] = Some(node.index());
        }
    }
    let local = |i: usize| -> Mat4 {
        let (t, r, _) = nodes[i].transform().decomposed();
        Mat4::from_rotation_translation(Quat::from_array(r).normalize(), Vec3::from_array(t))
    };
    // World transform of every node (scale left out), parents first by walking up.
    let mut world: Vec<Option<Mat4>> = vec![None; n];
    fn world_of(
        i: usize,
        parent: &[Option<usize>],
        local: &dyn Fn(usize) -> Mat4,
        world: &mut [Option<Mat4>],
        depth: usize,
    ) -> Result<Mat4, String> {
        if let Some(m) = world[i] {
            return Ok(m);
        }
        if depth > world.len() {
            return Err("the node hierarchy has a cycle".into());
        }
        let m = match parent[i] {
            Some(p) => world_of(p, parent, local, world, depth + 1)? * local(i),
            None => local(i),
        };
        world[i] = Some(m);
        Ok(m)
    }
    let in_skin: Vec<usize> = skin.joints().map(|j| j.index()).collect();
    if in_skin.len() > super::MAX_JOINTS {
        return Err(format!(
            "the skin has {} joints, more than {} (rig_target::MAX_JOINTS)",
            in_skin.len(),
            super::MAX_JOINTS
        ));
    }
    if in_skin.len() < 2 {
        return Err(format!(
            "the skin has {} joint(s): a rig needs at least two",
            in_skin.len()
        ));
    }
    let is_joint = |i: usize| in_skin.contains(&i);
    // Each joint's nearest ancestor that is a joint.
    let joint_parent = |i: usize| {
        let mut p = parent[i];
        while let Some(q) = p {
            if is_joint(q) {
                return Some(q);
            }
            p = parent[q];
        }
        None
    };
    // Parents-first order: depth-first from each skin root, children in skin order.
    let roots: Vec<usize> = in_skin
        .iter()
        .copied()
        .filter(|&i| joint_parent(i).is_none())
        .collect();
    let mut order: Vec<usize> = Vec::with_capacity(in_skin.len());
    let mut stack: Vec<usize> = roots.iter().rev().copied().collect();
    while let Some(i) = stack.pop() {
        order.push(i);
        let children: Vec<usize> = in_skin
            .iter()
            .copied()
            .filter(|&c| joint_parent(c) == Some(i))
            .collect();
        stack.extend(children.into_iter().rev());
    }
    let synthetic = roots.len() > 1;
    let mut joints = Vec::with_capacity(order.len() + usize::from(synthetic));
    if synthetic {
        joints.push(RigJoint {
            name: "__rig_root".into(),
            parent: None,
            rest_rotation: Quat::IDENTITY,
            rest_translation: Vec3::ZERO,
        });
    }
    let mut position = vec![usize::MAX; n];
    for &i in &order {
        let w = world_of(i, &parent, &local, &mut world, 0)?;
        let (rel, parent_joint) = match joint_parent(i) {
            Some(p) => {
                let wp = world_of(p, &parent, &local, &mut world, 0)?;
                (wp.inverse() * w, Some(position[p]))
            }
            None => (w, synthetic.then_some(0)),
        };
        let (_, r, t) = rel.to_scale_rotation_translation();
        position[i] = joints.len();
        joints.push(RigJoint {
            name: nodes[i]
                .name()
                .map(str::to_owned)
                .unwrap_or_else(|| format!("node{i}")),
            parent: parent_joint,
            rest_rotation: r.normalize(),
            rest_translation: t,
        });
    }
    Ok(joints)
}
