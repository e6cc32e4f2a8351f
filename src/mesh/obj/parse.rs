//! A small OBJ reader: positions in file order and fan-triangulated faces, nothing else.
//!
//! Supported: `v x y z` (extra numbers such as `w` or vertex colours are ignored), `f` with `v`,
//! `v/vt`, `v//vn` and `v/vt/vn` references, positive (1-based) and negative (relative) indices,
//! `#` comments and `\` line continuations. Every other statement (`vt`, `vn`, `o`, `g`, `s`,
//! `usemtl`, `mtllib`, `l`, `p`, ...) is ignored: objects and groups share one vertex list, as in the
//! file.

use glam::DVec3;

/// Positions in the order of the file's `v` lines and 0-based triangles (polygons fan-triangulated).
pub(super) type Parsed = (Vec<DVec3>, Vec<[usize; 3]>);

/// Parse OBJ text. Errors are `line N: what is wrong`.
pub(super) fn parse(text: &str) -> Result<Parsed, String> {
    let mut positions = Vec::new();
    // Faces with the line they came from: positive indices may refer to vertices defined later.
    let mut faces: Vec<(usize, Vec<usize>)> = Vec::new();
    for (line_no, statement) in statements(text) {
        let fail = |what: String| format!("line {line_no}: {what}");
        let mut tokens = statement.split_whitespace();
        match tokens.next() {
            Some("v") => {
                let mut xyz = [0.0; 3];
                for (k, c) in xyz.iter_mut().enumerate() {
                    let token = tokens.next().ok_or_else(|| fail(format!("vertex has {k} coordinates, expected 3")))?;
                    *c = token.parse().map_err(|_| fail(format!("vertex coordinate `{token}` is not a number")))?;
                }
                positions.push(DVec3::from_array(xyz));
            }
            Some("f") => {
                let refs = tokens
                    .map(|t| vertex_ref(t, positions.len()).map_err(&fail))
                    .collect::<Result<Vec<usize>, String>>()?;
                if refs.len() < 3 {
                    return Err(fail(format!("face has {} vertices, expected at least 3", refs.len())));
                }
                faces.push((line_no, refs));
            }
            _ => {}
        }
    }
    let mut triangles = Vec::with_capacity(faces.iter().map(|(_, f)| f.len() - 2).sum());
    for (line_no, refs) in faces {
        if let Some(&bad) = refs.iter().find(|&&v| v >= positions.len()) {
            return Err(format!(
                "line {line_no}: face refers to vertex {}, but the file has {}",
                bad + 1,
                positions.len()
            ));
        }
        triangles.extend(refs.windows(2).skip(1).map(|w| [refs[0], w[0], w[1]]));
    }
    Ok((positions, triangles))
}

/// Logical statements with their 1-based starting line: comments removed, `\` continuations joined.
fn statements(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut pending: Option<(usize, String)> = None;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split_once('#').map_or(raw, |(code, _)| code).trim_end();
        let (line, continues) = match line.strip_suffix('\\') {
            Some(head) => (head, true),
            None => (line, false),
        };
        let (start, mut joined) = pending.take().unwrap_or((i + 1, String::new()));
        joined.push(' ');
        joined.push_str(line);
        if continues {
            pending = Some((start, joined));
        } else {
            out.push((start, joined));
        }
    }
    out.extend(pending);
    out
}

/// The 0-based vertex index of a face reference such as `7`, `7/2`, `7//3` or `-1/2/3`, given the
/// number of vertices defined so far (negative indices count back from there).
fn vertex_ref(token: &str, defined: usize) -> Result<usize, String> {
    let v = token.split('/').next().unwrap_or(token);
    let bad = || format!("face vertex `{token}` is not a vertex index");
    let index: i64 = v.parse().map_err(|_| bad())?;
    match index {
        0 => Err(format!("face vertex `{token}`: OBJ indices start at 1")),
        i if i > 0 => usize::try_from(i - 1).map_err(|_| bad()),
        i => defined
            .checked_sub(usize::try_from(i.unsigned_abs()).map_err(|_| bad())?)
            .ok_or_else(|| format!("face vertex `{token}` reaches before the first vertex")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_file_order_and_triangulates_polygons() {
        let text =
            "# comment\nv 0 0 0\nv 1 0 0 1.0\nv 1 1 0 # trailing\nv 0 1 0 0.5 0.5 0.5\no a\nf 3/1 4//2 1/1/1 2\n";
        let (p, t) = parse(text).unwrap();
        assert_eq!(p, vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]);
        assert_eq!(t, vec![[2, 3, 0], [2, 0, 1]]);
    }

    #[test]
    fn negative_indices_continuations_and_forward_references() {
        let (p, t) = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nf 1 \\\n 3 4\nv 1 1 0\n").unwrap();
        assert_eq!(p.len(), 4);
        assert_eq!(t, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn errors_name_the_line() {
        let cases = [
            ("v 0 0 0\nv 1 banana 0\n", "line 2: vertex coordinate `banana` is not a number"),
            ("v 0 0\n", "line 1: vertex has 2 coordinates, expected 3"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 two 3\n", "line 4: face vertex `two` is not a vertex index"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "line 4: face has 2 vertices, expected at least 3"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", "line 4: face refers to vertex 7, but the file has 3"),
            ("v 0 0 0\nf 0 1 1\n", "line 2: face vertex `0`: OBJ indices start at 1"),
            ("v 0 0 0\nf -2 1 1\n", "line 2: face vertex `-2` reaches before the first vertex"),
        ];
        for (text, want) in cases {
            assert_eq!(parse(text).unwrap_err(), want);
        }
    }
}
