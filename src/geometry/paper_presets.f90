!> The seven bead models of the settlers paper as named presets: the parameters of the
!> appendix "Bead model of the particles used in the experiments" and the paper's L/d
!> (Table tab_mob_num), the length that makes the mobilities dimensionless.
!> How each value follows from the paper is documented in shapes/README.md.
module beadmob_paper_presets
  use beadmob_kinds, only: dp
  implicit none
  private
  public :: paper_shape_t, paper_shape_preset, is_paper_preset

  type :: paper_shape_t
    real(dp) :: reference_length = 0.0_dp
    real(dp) :: base_diameter = 0.0_dp, height = 0.0_dp
    real(dp) :: length = 0.0_dp, middle_height = 0.0_dp, width = 0.0_dp
    real(dp) :: semi_major = 0.0_dp, semi_minor = 0.0_dp, pipe_radius = 0.0_dp, gap_half_angle = 0.0_dp
    real(dp) :: scale = 0.0_dp, section_ratio = 0.0_dp
  end type paper_shape_t

  !> Measured sizes in mm (paper, section "Rigid particles").
  real(dp), parameter :: cone_diameter_mm = 4.39_dp, cone_height_mm = 10.45_dp
  real(dp), parameter :: arrow_length_mm = 6.28_dp, arrow_height_mm = 4.93_dp, arrow_middle_mm = 3.81_dp, &
                         arrow_width_mm = 2.33_dp

contains

  pure logical function is_paper_preset(name)
    character(len=*), intent(in) :: name
    is_paper_preset = any(name == [character(len=13) :: 'cone', 'arrowhead', 'crescent_moon', 'ring_1mm', &
                                   'ring_2mm', 'ring_3mm', 'ring_4mm'])
  end function is_paper_preset

  !> Parameters of a preset in units of the bead diameter; 'open_ring' has none (all required).
  pure function paper_shape_preset(name) result(preset)
    character(len=*), intent(in) :: name
    type(paper_shape_t) :: preset
    select case (name)
    case ('cone')
      preset%reference_length = 21.0_dp
      preset%base_diameter = 21.0_dp
      preset%height = 21.0_dp * cone_height_mm / cone_diameter_mm
    case ('arrowhead')
      preset%reference_length = 29.0_dp
      preset%length = 29.0_dp
      preset%height = 29.0_dp * arrow_height_mm / arrow_length_mm
      preset%middle_height = 29.0_dp * arrow_middle_mm / arrow_length_mm
      preset%width = 29.0_dp * arrow_width_mm / arrow_length_mm
    case ('crescent_moon')
      preset%reference_length = 55.0_dp
      preset%scale = 6.2_dp
      preset%section_ratio = 0.6_dp
    case ('ring_1mm')
      preset = ring(67.0_dp, 30.90_dp, 27.90_dp, 10.0_dp + 47.0_dp / 60.0_dp)
    case ('ring_2mm')
      preset = ring(73.0_dp, 33.72_dp, 27.60_dp, 20.0_dp + 32.0_dp / 60.0_dp)
    case ('ring_3mm')
      preset = ring(81.0_dp, 37.08_dp, 27.48_dp, 28.0_dp + 30.0_dp / 60.0_dp)
    case ('ring_4mm')
      preset = ring(85.0_dp, 39.06_dp, 27.36_dp, 36.0_dp + 35.0_dp / 60.0_dp)
    end select
  contains
    pure function ring(reference_length, semi_major, semi_minor, gap_half_angle) result(r)
      real(dp), intent(in) :: reference_length, semi_major, semi_minor, gap_half_angle
      type(paper_shape_t) :: r
      ! All four rings: pipe radius R = 3.6 d (paper, appendix "Open Ring", items (a)-(d)).
      r = paper_shape_t(reference_length=reference_length, semi_major=semi_major, semi_minor=semi_minor, &
                        pipe_radius=3.6_dp, gap_half_angle=gap_half_angle)
    end function ring
  end function paper_shape_preset
end module beadmob_paper_presets
