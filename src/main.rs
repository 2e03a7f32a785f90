//! `taut`: the host tool. Runs the stringing machine on its digital twin.
fn main() {
    println!("taut: host tool (work in progress)");
}
