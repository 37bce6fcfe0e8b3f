//! Job files: several sections, each a program with its index or setup and its frame
//! (`lampost post --job`). The CLI resolves the paths and builds the sections.

use std::collections::BTreeMap;

/// A job file: its sections in order.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct JobFile {
    /// The `[[section]]` tables.
    pub section: Vec<JobSection>,
}

/// One `[[section]]` of a job file.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct JobSection {
    /// The planar program, relative to the job file.
    pub program: String,
    /// Fixed rotary positions by axis name.
    pub index: Option<BTreeMap<String, f64>>,
    /// A setup file, relative to the job file (program +Z becomes the tool axis).
    pub setup: Option<String>,
    /// Program origin in the part frame.
    pub origin: Option<[f64; 3]>,
    /// Program X axis in the part frame.
    pub x_axis: Option<[f64; 3]>,
    /// Program Z axis in the part frame.
    pub z_axis: Option<[f64; 3]>,
}

/// Read a job file's text; the error carries its span (the CLI locates it).
pub fn parse(text: &str) -> Result<JobFile, toml::de::Error> {
    let job: JobFile = toml::from_str(text)?;
    if let Some((key, _, written, read)) = lampost_kinematics::dropped_elements(text, &job) {
        return Err(serde::de::Error::custom(format!(
            "`{key}` has {written} values; it takes {read}"
        )));
    }
    Ok(job)
}
