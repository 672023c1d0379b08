use super::*;

#[test]
fn names_round_trip() {
    for o in Operator::ALL {
        assert_eq!(o.name().parse::<Operator>().unwrap(), o);
    }
    assert_eq!(Operator::default(), Operator::Tumblin);
    let e = "drago".parse::<Operator>().unwrap_err().to_string();
    assert!(e.contains("drago") && e.contains("tumblin"), "{e}");
}
