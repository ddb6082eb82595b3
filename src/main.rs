fn main() {
    println!("pir");
}
