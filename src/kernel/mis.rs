//! Multiple importance sampling weights (Veach & Guibas 1995).

/// The power heuristic with β = 2 for one sample from each of two strategies: the weight of a sample
/// drawn with density `pdf_a` when the other strategy would have drawn it with `pdf_b`.
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    if a.is_infinite() {
        1.0
    } else if a + b == 0.0 {
        0.0
    } else {
        a / (a + b)
    }
}

#[cfg(test)]
mod tests {
    use super::power_heuristic;

    #[test]
    fn it_is_the_power_heuristic_not_the_balance_heuristic() {
        // pdfs 1 and 3: the power heuristic gives 1/10 and 9/10; the balance heuristic 1/4 and 3/4.
        assert!((power_heuristic(1.0, 3.0) - 0.1).abs() < 1e-7);
        assert!((power_heuristic(3.0, 1.0) - 0.9).abs() < 1e-7);
        for (a, b) in [(1.0, 2.0), (0.3, 0.0), (5.0, 5.0), (1e-20, 1e20)] {
            assert!((power_heuristic(a, b) + power_heuristic(b, a) - 1.0).abs() < 1e-6, "{a} {b}");
        }
        // A delta strategy (infinite pdf) takes all the weight; two zero pdfs none.
        assert_eq!(power_heuristic(f32::INFINITY, 1.0), 1.0);
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
    }
}
