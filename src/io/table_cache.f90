!> A file cache of the expensive tables of a friction job (docs/input.md, "Table cache"): the two-bead blocks of
!> canonical lattice displacements (block_table.f90) and the rigid-doublet lubrication corrections
!> per pair distance (lubrication.f90). They depend on the multipole truncation and the formulas
!> only, never on the body, so a run takes every entry an earlier run computed and adds the ones
!> it lacks. One HDF5 file, read and written serially (only rank 0 calls this module):
!>   /                     attributes format = 'beadmob-table-cache', format_version
!>   /blocks/<name>        attribute key; displacements int (3, n), blocks float64 (nb, nb, n)
!>   /lubrication/<name>   attribute key; distances float64 (n), corrections float64 (4, n)
!> (Fortran order; C readers see the dimensions reversed.) An entry is used only when its key text
!> equals the run's exactly: the key lists everything that changes the numbers. Datasets carry
!> Fletcher-32 checksums and the metadata HDF5's own, so damage is reported as an error, which
!> the callers turn into a warning and a full computation. An update is written to a temporary
!> file in the same directory and renamed over the cache: readers see the old or the new file,
!> never a half-written one (of two runs updating at once, the last rename wins).
module beadmob_table_cache
  use, intrinsic :: iso_c_binding, only: c_int
  use, intrinsic :: iso_fortran_env, only: error_unit
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use hdf5
  use beadmob_file_system, only: rename_file, remove_file
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_hdf5_support, only: write_attribute, read_text_attribute, read_int_attribute
  implicit none
  private
  public :: cache_key_t, read_cached_blocks, write_cached_blocks, read_cached_lubrication, write_cached_lubrication
  public :: warn_cache, cache_format, cache_format_version

  character(len=*), parameter :: cache_format = 'beadmob-table-cache'
  integer, parameter :: cache_format_version = 1
  character(len=*), parameter :: sections(2) = [character(len=11) :: 'blocks', 'lubrication']
  !> Elements per dataset chunk (the unit of the checksum): about 1 MB.
  integer(i8), parameter :: chunk_elements = 131072

  !> What identifies a cache entry.
  type :: cache_key_t
    character(len=:), allocatable :: name   ! the entry's name in its section, e.g. 'L2_L2_0'
    character(len=:), allocatable :: text   ! everything the numbers depend on: must match exactly
  end type cache_key_t

  interface
    integer(c_int) function c_getpid() bind(c, name='getpid')
      import :: c_int
    end function c_getpid
  end interface

contains

  !> One warning line on the error unit (callers: rank 0 only).
  subroutine warn_cache(path, message)
    character(len=*), intent(in) :: path, message
    write (error_unit, '(a)') "beadmob: warning: table cache '" // path // "': " // message
  end subroutine warn_cache

  !> The blocks entry of `key`: displacements (3, n), blocks (block_size, block_size, n); n = 0
  !> when the file or the entry does not exist. A damaged or mismatched entry raises `err` (and
  !> returns n = 0).
  subroutine read_cached_blocks(path, key, block_size, displacements, blocks, err)
    character(len=*), intent(in) :: path
    type(cache_key_t), intent(in) :: key
    integer, intent(in) :: block_size
    integer, allocatable, intent(out) :: displacements(:, :)
    real(dp), allocatable, intent(out) :: blocks(:, :, :)
    type(error_t), intent(inout) :: err
    integer(hid_t) :: file_id, entry, dataset
    integer :: n, status, j
    logical :: found

    allocate (displacements(3, 0), blocks(block_size, block_size, 0))
    call open_entry(path, 'blocks', key, file_id, entry, found, err)
    if (found .and. .not. err%failed) then
      n = -1
      call open_dataset(entry, '/blocks/' // key%name, 'displacements', [3, -1], dataset, n, err)
      if (.not. err%failed) then
        deallocate (displacements)
        allocate (displacements(3, n))
        call h5dread_f(dataset, H5T_NATIVE_INTEGER, displacements, int(shape(displacements), hsize_t), status)
        call check(status, 'read dataset displacements of entry /blocks/' // key%name // ' (damaged file?)', err)
        call h5dclose_f(dataset, status)
      end if
      if (.not. err%failed) &
        call open_dataset(entry, '/blocks/' // key%name, 'blocks', [block_size, block_size, -1], dataset, n, err)
      if (.not. err%failed) then
        deallocate (blocks)
        allocate (blocks(block_size, block_size, n))
        call h5dread_f(dataset, H5T_NATIVE_DOUBLE, blocks, int(shape(blocks), hsize_t), status)
        call check(status, 'read dataset blocks of entry /blocks/' // key%name // ' (damaged file?)', err)
        call h5dclose_f(dataset, status)
      end if
      if (.not. err%failed) then
        ! Canonical displacements only (d1 >= d2 >= d3 >= 0, not 0): anything else is not ours.
        do j = 1, size(displacements, 2)
          if (displacements(1, j) < displacements(2, j) .or. displacements(2, j) < displacements(3, j) .or. &
              displacements(3, j) < 0 .or. displacements(1, j) == 0) then
            call raise(err, 'entry /blocks/' // key%name // ' holds the non-canonical displacement (' // &
                       str(displacements(1, j)) // ', ' // str(displacements(2, j)) // ', ' // &
                       str(displacements(3, j)) // ')')
            exit
          end if
        end do
      end if
      if (.not. err%failed .and. .not. all(ieee_is_finite(blocks))) &
        call raise(err, 'entry /blocks/' // key%name // ' holds non-finite numbers')
    end if
    if (found) call h5fclose_f(file_id, status)
    if (err%failed) then
      deallocate (displacements, blocks)
      allocate (displacements(3, 0), blocks(block_size, block_size, 0))
    end if
  end subroutine read_cached_blocks

  !> The lubrication entry of `key`: distances (n), corrections (4, n); n = 0 when absent.
  !> Errors as read_cached_blocks.
  subroutine read_cached_lubrication(path, key, distances, corrections, err)
    character(len=*), intent(in) :: path
    type(cache_key_t), intent(in) :: key
    real(dp), allocatable, intent(out) :: distances(:)
    real(dp), allocatable, intent(out) :: corrections(:, :)
    type(error_t), intent(inout) :: err
    integer(hid_t) :: file_id, entry, dataset
    integer :: n, status
    logical :: found

    allocate (distances(0), corrections(4, 0))
    call open_entry(path, 'lubrication', key, file_id, entry, found, err)
    if (found .and. .not. err%failed) then
      n = -1
      call open_dataset(entry, '/lubrication/' // key%name, 'distances', [-1], dataset, n, err)
      if (.not. err%failed) then
        deallocate (distances)
        allocate (distances(n))
        call h5dread_f(dataset, H5T_NATIVE_DOUBLE, distances, [int(n, hsize_t)], status)
        call check(status, 'read dataset distances of entry /lubrication/' // key%name // ' (damaged file?)', err)
        call h5dclose_f(dataset, status)
      end if
      if (.not. err%failed) &
        call open_dataset(entry, '/lubrication/' // key%name, 'corrections', [4, -1], dataset, n, err)
      if (.not. err%failed) then
        deallocate (corrections)
        allocate (corrections(4, n))
        call h5dread_f(dataset, H5T_NATIVE_DOUBLE, corrections, int(shape(corrections), hsize_t), status)
        call check(status, 'read dataset corrections of entry /lubrication/' // key%name // ' (damaged file?)', err)
        call h5dclose_f(dataset, status)
      end if
      if (.not. err%failed) then
        if (.not. (all(ieee_is_finite(corrections)) .and. all(ieee_is_finite(distances)) .and. all(distances > 0.0_dp))) &
          call raise(err, 'entry /lubrication/' // key%name // ' holds non-finite numbers or non-positive distances')
      end if
    end if
    if (found) call h5fclose_f(file_id, status)
    if (err%failed) then
      deallocate (distances, corrections)
      allocate (distances(0), corrections(4, 0))
    end if
  end subroutine read_cached_lubrication

  !> Replace the blocks entry of `key` by these (n >= 1) and keep every other entry of the file.
  subroutine write_cached_blocks(path, key, displacements, blocks, err)
    character(len=*), intent(in) :: path
    type(cache_key_t), intent(in) :: key
    integer, intent(in) :: displacements(:, :)
    real(dp), intent(in) :: blocks(:, :, :)
    type(error_t), intent(inout) :: err
    integer(hid_t) :: file_id, entry, dataset
    character(len=:), allocatable :: temporary
    integer :: status

    if (size(displacements, 2) == 0) return
    call begin_update(path, 'blocks', key, temporary, file_id, entry, err)
    if (.not. err%failed) then
      call create_checked_dataset(entry, 'displacements', H5T_STD_I32LE, int(shape(displacements), hsize_t), dataset, err)
      if (.not. err%failed) then
        call h5dwrite_f(dataset, H5T_NATIVE_INTEGER, displacements, int(shape(displacements), hsize_t), status)
        call check(status, 'write dataset displacements', err)
        call h5dclose_f(dataset, status)
      end if
    end if
    if (.not. err%failed) then
      call create_checked_dataset(entry, 'blocks', H5T_IEEE_F64LE, int(shape(blocks), hsize_t), dataset, err)
      if (.not. err%failed) then
        call h5dwrite_f(dataset, H5T_NATIVE_DOUBLE, blocks, int(shape(blocks), hsize_t), status)
        call check(status, 'write dataset blocks', err)
        call h5dclose_f(dataset, status)
      end if
    end if
    call finish_update(path, temporary, file_id, err)
  end subroutine write_cached_blocks

  !> Replace the lubrication entry of `key` by these (n >= 1) and keep every other entry.
  subroutine write_cached_lubrication(path, key, distances, corrections, err)
    character(len=*), intent(in) :: path
    type(cache_key_t), intent(in) :: key
    real(dp), intent(in) :: distances(:), corrections(:, :)
    type(error_t), intent(inout) :: err
    integer(hid_t) :: file_id, entry, dataset
    character(len=:), allocatable :: temporary
    integer :: status

    if (size(distances) == 0) return
    call begin_update(path, 'lubrication', key, temporary, file_id, entry, err)
    if (.not. err%failed) then
      call create_checked_dataset(entry, 'distances', H5T_IEEE_F64LE, [int(size(distances), hsize_t)], dataset, err)
      if (.not. err%failed) then
        call h5dwrite_f(dataset, H5T_NATIVE_DOUBLE, distances, [int(size(distances), hsize_t)], status)
        call check(status, 'write dataset distances', err)
        call h5dclose_f(dataset, status)
      end if
    end if
    if (.not. err%failed) then
      call create_checked_dataset(entry, 'corrections', H5T_IEEE_F64LE, int(shape(corrections), hsize_t), dataset, err)
      if (.not. err%failed) then
        call h5dwrite_f(dataset, H5T_NATIVE_DOUBLE, corrections, int(shape(corrections), hsize_t), status)
        call check(status, 'write dataset corrections', err)
        call h5dclose_f(dataset, status)
      end if
    end if
    call finish_update(path, temporary, file_id, err)
  end subroutine write_cached_lubrication

  ! ---------------------------------------------------------------------------------------------

  subroutine check(hdf_status, what, err)
    integer, intent(in) :: hdf_status
    character(len=*), intent(in) :: what
    type(error_t), intent(inout) :: err
    if (hdf_status < 0) call raise(err, 'HDF5 failed to ' // what)
  end subroutine check

  !> File access: newer metadata format (HDF5 >= 1.8, with checksums) and every object closed
  !> with the file (so error paths leak nothing).
  function file_access() result(access)
    integer(hid_t) :: access
    integer :: status
    call h5pcreate_f(H5P_FILE_ACCESS_F, access, status)
    call h5pset_libver_bounds_f(access, H5F_LIBVER_V18_F, H5F_LIBVER_LATEST_F, status)
    call h5pset_fclose_degree_f(access, H5F_CLOSE_STRONG_F, status)
  end function file_access

  !> Open `path` read-only and check that it is a table cache of this format version.
  subroutine open_cache_file(path, file_id, err)
    character(len=*), intent(in) :: path
    integer(hid_t), intent(out) :: file_id
    type(error_t), intent(inout) :: err
    integer(hid_t) :: access
    integer :: status, closed, version
    character(len=:), allocatable :: format
    access = file_access()
    call h5fopen_f(path, H5F_ACC_RDONLY_F, file_id, status, access_prp=access)
    call h5pclose_f(access, closed)
    if (status < 0) then
      file_id = -1
      call raise(err, 'not readable as an HDF5 file')
      return
    end if
    call read_text_attribute(file_id, 'format', format, err)
    if (.not. err%failed) then
      if (format /= cache_format) call raise(err, "not a table cache (format '" // format // "')")
    end if
    if (.not. err%failed) then
      call read_int_attribute(file_id, 'format_version', version, err)
      if (.not. err%failed .and. version /= cache_format_version) &
        call raise(err, 'format_version ' // str(version) // ', this beadmob reads ' // str(cache_format_version))
    end if
    if (err%failed) then
      call h5fclose_f(file_id, status)
      file_id = -1
    end if
  end subroutine open_cache_file

  !> Open the file and the entry /section/<key name>. found = .false. (and nothing open) when the
  !> file or the entry does not exist; with found = .true. the caller closes file_id. A key text
  !> different from the run's raises err.
  subroutine open_entry(path, section, key, file_id, entry, found, err)
    character(len=*), intent(in) :: path, section
    type(cache_key_t), intent(in) :: key
    integer(hid_t), intent(out) :: file_id, entry
    logical, intent(out) :: found
    type(error_t), intent(inout) :: err
    logical :: exists
    integer :: status
    character(len=:), allocatable :: stored
    found = .false.
    entry = -1
    inquire (file=path, exist=exists)
    if (.not. exists) return   ! a new cache: nothing to read
    call open_cache_file(path, file_id, err)
    if (err%failed) return
    call h5lexists_f(file_id, section, exists, status)
    if (status >= 0 .and. exists) call h5lexists_f(file_id, section // '/' // key%name, exists, status)
    if (status < 0) call raise(err, 'cannot look up entry /' // section // '/' // key%name)
    if (err%failed .or. .not. exists) then
      call h5fclose_f(file_id, status)
      return
    end if
    found = .true.
    call h5gopen_f(file_id, section // '/' // key%name, entry, status)
    call check(status, 'open entry /' // section // '/' // key%name, err)
    if (err%failed) return
    call read_text_attribute(entry, 'key', stored, err)
    if (.not. err%failed .and. stored /= key%text) &
      call raise(err, 'entry /' // section // '/' // key%name // " was made with other parameters (its key: '" // &
                 stored // "')")
  end subroutine open_entry

  !> Open dataset `name` of `entry` and check its shape against `expected`, where -1 marks the
  !> entry count n: returned when n < 0 on entry, else the dataset must agree with it.
  subroutine open_dataset(entry, where, name, expected, dataset, n, err)
    integer(hid_t), intent(in) :: entry
    character(len=*), intent(in) :: where, name   ! where: the entry's path, for messages
    integer, intent(in) :: expected(:)
    integer(hid_t), intent(out) :: dataset
    integer, intent(inout) :: n
    type(error_t), intent(inout) :: err
    integer(hid_t) :: space
    integer(hsize_t) :: dims(size(expected)), max_dims(size(expected))
    integer :: status, rank, k
    logical :: fits
    call h5dopen_f(entry, name, dataset, status)
    if (status < 0) then
      call raise(err, 'cannot open dataset ' // name // ' of entry ' // where)
      return
    end if
    call h5dget_space_f(dataset, space, status)
    call h5sget_simple_extent_ndims_f(space, rank, status)
    fits = status >= 0 .and. rank == size(expected)
    if (fits) then
      call h5sget_simple_extent_dims_f(space, dims, max_dims, status)
      fits = status >= 0
    end if
    call h5sclose_f(space, status)
    if (fits) then
      do k = 1, size(expected)
        if (expected(k) >= 0) then
          fits = fits .and. dims(k) == expected(k)
        else
          if (n < 0 .and. dims(k) <= huge(n)) n = int(dims(k))
          fits = fits .and. dims(k) == n
        end if
      end do
    end if
    if (.not. fits) then
      call raise(err, 'dataset ' // name // ' of entry ' // where // ' has an unexpected shape')
      call h5dclose_f(dataset, status)
    end if
  end subroutine open_dataset

  !> Create the temporary file next to `path`, copy every entry of the old cache (when it is a
  !> readable cache) except /section/<key name>, and create that entry's group with its key.
  subroutine begin_update(path, section, key, temporary, file_id, entry, err)
    character(len=*), intent(in) :: path, section
    type(cache_key_t), intent(in) :: key
    character(len=:), allocatable, intent(out) :: temporary
    integer(hid_t), intent(out) :: file_id, entry
    type(error_t), intent(inout) :: err
    integer(hid_t) :: access, group
    integer :: status, closed, s
    ! The process id keeps concurrent runs from sharing a temporary file.
    temporary = path // '.tmp' // str(int(c_getpid()))
    entry = -1
    access = file_access()
    call h5fcreate_f(temporary, H5F_ACC_TRUNC_F, file_id, status, access_prp=access)
    call h5pclose_f(access, closed)
    if (status < 0) then
      file_id = -1
      call raise(err, "cannot create '" // temporary // "'")
      return
    end if
    call write_attribute(file_id, 'format', cache_format, err)
    call write_attribute(file_id, 'format_version', cache_format_version, err)
    do s = 1, size(sections)
      call h5gcreate_f(file_id, trim(sections(s)), group, status)
      call check(status, 'create group ' // trim(sections(s)), err)
      call h5gclose_f(group, status)
    end do
    if (err%failed) return
    call copy_other_entries(path, file_id, section, key%name)
    call h5gcreate_f(file_id, section // '/' // key%name, entry, status)
    call check(status, 'create entry /' // section // '/' // key%name, err)
    if (.not. err%failed) call write_attribute(entry, 'key', key%text, err)
  end subroutine begin_update

  !> Entries of an unreadable old file, or that fail to copy, are dropped: the cache only ever
  !> saves work, it never has to keep anything.
  subroutine copy_other_entries(path, new_file, skip_section, skip_name)
    character(len=*), intent(in) :: path, skip_section, skip_name
    integer(hid_t), intent(in) :: new_file
    type(error_t) :: ignored
    integer(hid_t) :: old_file, old_group, new_group
    integer(size_t) :: name_length
    integer :: status, s, storage, max_order, k, n_links
    logical :: exists
    character(len=256) :: name
    inquire (file=path, exist=exists)
    if (.not. exists) return
    call open_cache_file(path, old_file, ignored)
    if (ignored%failed) return
    do s = 1, size(sections)
      call h5lexists_f(old_file, trim(sections(s)), exists, status)
      if (status < 0 .or. .not. exists) cycle
      call h5gopen_f(old_file, trim(sections(s)), old_group, status)
      if (status < 0) cycle
      call h5gopen_f(new_file, trim(sections(s)), new_group, status)
      call h5gget_info_f(old_group, storage, n_links, max_order, status)
      if (status < 0) n_links = 0
      do k = 0, n_links - 1
        call h5lget_name_by_idx_f(old_group, '.', H5_INDEX_NAME_F, H5_ITER_INC_F, int(k, hsize_t), name, status, &
                                  name_length)
        if (status < 0 .or. name_length > len(name)) cycle
        if (trim(sections(s)) == skip_section .and. name == skip_name) cycle
        call h5ocopy_f(old_group, trim(name), new_group, trim(name), status)
      end do
      call h5gclose_f(new_group, status)
      call h5gclose_f(old_group, status)
    end do
    call h5fclose_f(old_file, status)
  end subroutine copy_other_entries

  !> Chunked with Fletcher-32 checksums (n >= 1 in the last dimension).
  subroutine create_checked_dataset(entry, name, file_type, dims, dataset, err)
    integer(hid_t), intent(in) :: entry, file_type
    character(len=*), intent(in) :: name
    integer(hsize_t), intent(in) :: dims(:)
    integer(hid_t), intent(out) :: dataset
    type(error_t), intent(inout) :: err
    integer(hid_t) :: space, creation
    integer(hsize_t) :: chunk(size(dims))
    integer :: status, last
    last = size(dims)
    chunk = dims
    chunk(last) = max(1_hsize_t, min(dims(last), int(chunk_elements, hsize_t) / max(product(dims(1:last - 1)), 1_hsize_t)))
    call h5screate_simple_f(last, dims, space, status)
    call h5pcreate_f(H5P_DATASET_CREATE_F, creation, status)
    call h5pset_chunk_f(creation, last, chunk, status)
    call h5pset_fletcher32_f(creation, status)
    call h5dcreate_f(entry, name, file_type, space, dataset, status, dcpl_id=creation)
    call check(status, 'create dataset ' // name, err)
    call h5pclose_f(creation, status)
    call h5sclose_f(space, status)
  end subroutine create_checked_dataset

  !> Close the temporary file and rename it over the cache; on any failure remove it instead.
  subroutine finish_update(path, temporary, file_id, err)
    character(len=*), intent(in) :: path, temporary
    integer(hid_t), intent(in) :: file_id
    type(error_t), intent(inout) :: err
    integer :: status
    if (file_id >= 0) then
      call h5fclose_f(file_id, status)
      call check(status, "close '" // temporary // "'", err)
    end if
    if (.not. err%failed) then
      if (.not. rename_file(temporary, path)) &
        call raise(err, "cannot rename '" // temporary // "' to '" // path // "'")
    end if
    if (err%failed) call remove_file(temporary)
  end subroutine finish_update
end module beadmob_table_cache
