//! The calibrated machine file as a person would write it: an edit of the original
//! machine file's text (its comments, order and layout kept, `toml_edit`), with only the
//! calibrated numbers replaced, each rounded to a digit below its measured uncertainty
//! (no `4.440892098500626e-16`), a distinct name, one more line under `assumptions`, and a
//! `[calibration]` table saying where the numbers came from.

use lampost_kinematics::{Machine, MachineDef, ParamValue, VecExpr};
use toml_edit::{value, Array, DocumentMut, Item, Table};

use crate::calib::{updated_machine, PivotResult};
use crate::error::AlignError;

/// The decimals that keep a number measured with standard uncertainty `u` to one digit
/// below it: `u` = 2e-5 → 6 decimals. Between 4 and 12; 9 when nothing is known.
pub fn decimals_for(u: Option<f64>) -> usize {
    match u {
        Some(u) if u.is_finite() && u > 0.0 => {
            let d = (-u.log10()).ceil() + 1.0;
            d.clamp(4.0, 12.0) as usize
        }
        _ => 9,
    }
}

/// `x` rounded to `decimals` places, `-0` made `0`.
fn round(x: f64, decimals: usize) -> f64 {
    let k = 10f64.powi(decimals as i32);
    let r = (x * k).round() / k;
    if r == 0.0 {
        0.0
    } else {
        r
    }
}

fn array(v: [f64; 3], decimals: usize) -> Item {
    let mut a = Array::new();
    for x in v {
        a.push(round(x, decimals));
    }
    value(a)
}

/// Replace `key`'s value, keeping the comments above the key (a new key if absent).
fn set_keeping_comments(t: &mut dyn toml_edit::TableLike, key: &str, item: Item) {
    match t.get_mut(key) {
        Some(slot) => *slot = item,
        None => {
            t.insert(key, item);
        }
    }
}

fn bad(what: String) -> AlignError {
    AlignError::Calibration {
        what,
        hint: "give the machine file the calibration started from, unedited since",
    }
}

/// The machine file `original` (the text of `m`'s file, or of the built-in it names)
/// with the pivot calibration `res`, measured from `source`, applied. The result is read
/// back and must build a machine whose calibrated values are the rounded ones.
pub fn calibrated_text(
    original: &str,
    m: &Machine,
    res: &PivotResult,
    source: &str,
) -> Result<String, AlignError> {
    let def = updated_machine(m, res)?;
    let mut doc: DocumentMut = original
        .parse()
        .map_err(|e| bad(format!("the machine file does not parse as TOML: {e}")))?;
    let u_min = res
        .u_r
        .map(|u| u.iter().copied().fold(f64::INFINITY, f64::min));
    let dec = decimals_for(u_min);
    // A distinct name, so that a posted header says which file it came from.
    let name = if m.def.name.ends_with("-cal") {
        m.def.name.clone()
    } else {
        format!("{}-cal", m.def.name)
    };
    doc["name"] = value(name.as_str());
    // The parameters the calibration changed.
    for (k, v) in &def.parameters {
        if m.def.parameters.get(k) == Some(v) {
            continue;
        }
        if let ParamValue::Vector(x) = v {
            let params = doc
                .get_mut("parameters")
                .and_then(Item::as_table_like_mut)
                .ok_or_else(|| bad("the machine file has no [parameters] table".into()))?;
            set_keeping_comments(params, k, array(*x, dec));
        }
    }
    // The rotary axes the calibration changed (the axis-line fit).
    let rotary = doc
        .get_mut("rotary")
        .and_then(Item::as_array_of_tables_mut)
        .ok_or_else(|| bad("the machine file has no [[rotary]] tables".into()))?;
    for (i, (new, old)) in def.rotary.iter().zip(&m.def.rotary).enumerate() {
        let t = rotary
            .get_mut(i)
            .ok_or_else(|| bad(format!("the machine file has no rotary axis {}", i + 1)))?;
        if new.axis != old.axis {
            set_keeping_comments(t, "axis", array(new.axis, 9));
        }
        if new.pivot != old.pivot {
            if let VecExpr::Literal(p) = new.pivot {
                set_keeping_comments(t, "pivot", array(p, dec));
            }
        }
    }
    // One more assumption, and the record of the calibration.
    if let Some(a) = doc.get_mut("assumptions").and_then(Item::as_array_mut) {
        if let Some(last) = def.assumptions.last() {
            // On its own line, as the others are when the array spans lines.
            let multiline = a
                .iter()
                .next()
                .and_then(|v| v.decor().prefix())
                .and_then(|p| p.as_str())
                .is_some_and(|p| p.contains('\n'));
            a.push(last.as_str());
            if multiline {
                if let Some(v) = a.iter_mut().last() {
                    v.decor_mut().set_prefix("\n  ");
                }
            }
        }
    }
    let mut cal = Table::new();
    cal.decor_mut().set_prefix(
        "\n# Written by lampost calibrate pivot: where the calibrated numbers above came from.\n",
    );
    cal.insert("source", value(source));
    cal.insert("method", value(format!("{:?}", res.method).to_lowercase()));
    cal.insert("poses", value(res.per_pose.len() as i64));
    cal.insert("rms", value(round(res.rms, 12)));
    let worst = res.per_pose.iter().map(|p| p.norm).fold(0.0, f64::max);
    cal.insert("max_pose_residual", value(round(worst, 12)));
    if let Some(u) = res.u_r {
        let mut a = Array::new();
        for x in u {
            a.push(round(x, 12));
        }
        cal.insert("u_R", value(a));
    }
    cal.insert("calibrated_from", value(m.def.name.as_str()));
    doc["calibration"] = Item::Table(cal);
    let text = doc.to_string();
    // Read back: the file must build a machine, with the rounded numbers.
    let back = MachineDef::from_toml(&text, &name).map_err(|e| {
        bad(format!(
            "the calibrated machine file does not read back: {e}"
        ))
    })?;
    Machine::new(back.clone(), &[])
        .map_err(|e| bad(format!("the calibrated machine file does not build: {e}")))?;
    if let (Some(ParamValue::Vector(r)), Some(ParamValue::Vector(w))) =
        (back.parameters.get("R"), def.parameters.get("R"))
    {
        if (0..3).any(|k| (r[k] - round(w[k], dec)).abs() > 0.0) {
            return Err(bad("the calibrated R did not survive the round trip".into()));
        }
    }
    Ok(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimals_follow_the_uncertainty() {
        assert_eq!(decimals_for(Some(2e-5)), 6);
        assert_eq!(decimals_for(Some(3e-3)), 4);
        assert_eq!(decimals_for(Some(1e-15)), 12);
        assert_eq!(decimals_for(None), 9);
        assert_eq!(round(-1e-13, 6), 0.0);
        assert!(round(-1e-13, 6).is_sign_positive());
        assert_eq!(round(4.440892098500626e-16, 9), 0.0);
    }
}
