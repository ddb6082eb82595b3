//! Reading a study's `snapshots.csv` back, for tests that judge methods by a study's numbers.

use std::path::Path;

pub struct Row {
    pub label: String,
    pub time: f64,
    pub iterations: u64,
    pub rmse: f64,
    pub rel_mse: f64,
    pub flip: f64,
    pub max_rel_se: f64,
    pub mean_rel_diff: f64,
}

pub fn read_csv(path: &Path) -> Vec<Row> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "label,method,parameters,time_s,iterations,rmse,rel_mse,hdr_flip,max_rel_se,mean_rel_diff"
    );
    lines
        .map(|l| {
            let f = fields(l);
            assert_eq!(f.len(), 10, "{l}");
            Row {
                label: f[0].to_string(),
                time: f[3].parse().unwrap(),
                iterations: f[4].parse().unwrap(),
                rmse: f[5].parse().unwrap(),
                rel_mse: f[6].parse().unwrap(),
                flip: f[7].parse().unwrap(),
                max_rel_se: f[8].parse().unwrap(),
                mean_rel_diff: f[9].parse().unwrap(),
            }
        })
        .collect()
}

/// The fields of one CSV row; a field in double quotes may hold commas and doubled quotes.
fn fields(line: &str) -> Vec<String> {
    let (mut out, mut cur, mut quoted) = (Vec::new(), String::new(), false);
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            ('"', _) => quoted = !quoted,
            (',', false) => out.push(std::mem::take(&mut cur)),
            _ => cur.push(c),
        }
    }
    out.push(cur);
    out
}

/// The rows of one line, in snapshot order.
pub fn line<'a>(rows: &'a [Row], label: &str) -> Vec<&'a Row> {
    rows.iter().filter(|r| r.label == label).collect()
}
